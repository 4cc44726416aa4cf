"""The reference policy that places tasks on the ladder: LadderFlow, protocol v4.

`encoders`: frozen pretrained image encoders (EfficientNet-Lite0 ImageNet weights, offline, instead of the
paper's RADIO); `flow`: the flow-matching transformer, its training on cached features and checkpoints;
`features`: demo frames rendered and encoded once; `evaluate`: a checkpoint as a `maniladder eval` policy;
`calibrate`: `maniladder calibrate`, demos -> features -> train -> evaluate -> a measured level; `records`: a
task's calibration record (the refinement rounds and final runs, `maniladder calibrate --record`).
"""

from .flow import PROTOCOL_VERSION, LadderFlowConfig, LadderFlowPolicy, LadderFlowTrainer

__all__ = ["PROTOCOL_VERSION", "LadderFlowConfig", "LadderFlowPolicy", "LadderFlowTrainer"]
