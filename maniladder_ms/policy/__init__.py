"""The reference policy that places tasks on the ladder (issue 20, in progress): LadderFlow protocol v1.

`encoders`: frozen pretrained image encoders (EfficientNet-Lite0 ImageNet weights, offline, instead of the
paper's RADIO); `flow`: the flow-matching transformer, its training on cached features and checkpoints.
Rollouts, feature caching from demos and `maniladder calibrate` are not built yet.
"""

from .flow import PROTOCOL_VERSION, LadderFlowConfig, LadderFlowPolicy, LadderFlowTrainer

__all__ = ["PROTOCOL_VERSION", "LadderFlowConfig", "LadderFlowPolicy", "LadderFlowTrainer"]
