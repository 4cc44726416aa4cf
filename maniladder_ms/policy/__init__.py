"""The reference policy that places tasks on the ladder (issue 20, in progress): LadderFlow protocol v3.

`encoders`: frozen pretrained image encoders (EfficientNet-Lite0 ImageNet weights, offline, instead of the
paper's RADIO); `flow`: the flow-matching transformer, its training on cached features and checkpoints;
`features`: demo frames rendered and encoded once; `evaluate`: a checkpoint as a `maniladder eval` policy;
`calibrate`: `maniladder calibrate`, demos -> features -> train -> select -> evaluate -> a measured level.
"""

from .flow import PROTOCOL_VERSION, LadderFlowConfig, LadderFlowPolicy, LadderFlowTrainer

__all__ = ["PROTOCOL_VERSION", "LadderFlowConfig", "LadderFlowPolicy", "LadderFlowTrainer"]
