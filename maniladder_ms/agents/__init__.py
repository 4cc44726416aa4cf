"""ManiLadder embodiments as registered ManiSkill agents, and their motion helpers.

Importing this package registers `ml_panda`, `ml_panda_leap`, `ml_dual_panda`, `ml_dual_panda_leap`
and `ml_tidybot` with ManiSkill (`robot_uids=` of any task that lists them in SUPPORTED_ROBOTS).
"""

from .robots import MLDualPanda, MLDualPandaLeap, MLPanda, MLPandaLeap, MLTidyBot

AGENT_UIDS = ("ml_panda", "ml_panda_leap", "ml_dual_panda", "ml_dual_panda_leap", "ml_tidybot")

__all__ = ["AGENT_UIDS", "MLPanda", "MLPandaLeap", "MLDualPanda", "MLDualPandaLeap", "MLTidyBot"]
