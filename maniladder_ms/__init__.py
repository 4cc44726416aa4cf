"""ManiLadder-MS: a difficulty-calibrated manipulation benchmark as a ManiSkill3 task pack.

`import maniladder_ms` registers every implemented task as `ManiLadder-<TaskId>-v1` in ManiSkill's
gym registry.
"""

from __future__ import annotations

__version__ = "0.1.0"

from .catalog import Catalog, CatalogError, TaskSpec, UnknownTaskError, default_catalog, load_catalog
from . import agents  # noqa: F401  (registers the agents; first: the base env uses agents.effectors)
from .envs import ManiLadderEnv, UnsupportedControlModeError, UnsupportedRobotError
from . import tasks  # noqa: F401  (registers the envs; their modules are imported on first use)


class TaskNotImplementedError(NotImplementedError):
    """A catalog task whose env has not been built yet."""


def make(task_id: str, **kwargs):
    """`gym.make` for a ManiLadder task by catalog id, with clear errors for unknown/unbuilt tasks."""
    import gymnasium as gym

    spec = default_catalog().get(task_id)
    if not spec.implemented:
        raise TaskNotImplementedError(
            f"task {spec.id} ({spec.suite}) is in the catalog but not implemented yet; "
            "`maniladder list --implemented` shows the ones that are"
        )
    return gym.make(spec.env_id, **kwargs)
