"""ManiLadder embodiments as registered ManiSkill agents, and their motion helpers.

Importing this package registers `ml_panda`, `ml_panda_leap`, `ml_dual_panda`, `ml_dual_panda_leap`
and `ml_tidybot` with ManiSkill (`robot_uids=` of any task that lists them in SUPPORTED_ROBOTS), and
the `ManiLadder-AgentGallery-v1` env that shows any of them in the empty ladder scene.
"""

from .robots import MLDualPanda, MLDualPandaLeap, MLPanda, MLPandaLeap, MLTidyBot

AGENT_UIDS = ("ml_panda", "ml_panda_leap", "ml_dual_panda", "ml_dual_panda_leap", "ml_tidybot")

from . import gallery  # noqa: E402,F401  (registers the gallery env; needs AGENT_UIDS)

__all__ = ["AGENT_UIDS", "MLPanda", "MLPandaLeap", "MLDualPanda", "MLDualPandaLeap", "MLTidyBot"]
