"""Registering ManiLadder tasks in ManiSkill's (and gymnasium's) env registry from the catalog."""

from mani_skill.utils.registration import register_env

from maniladder_ms.catalog import default_catalog


def register_task(task_id: str, **default_kwargs):
    """Class decorator: register `ManiLadder-<task_id>-v1` with the catalog's horizon as max_episode_steps.

    Stack several on one class for a family that differs by parameters (e.g. number of blocks).
    """
    spec = default_catalog().get(task_id)

    def decorate(cls):
        register_env(spec.env_id, max_episode_steps=spec.horizon, task_id=task_id, **default_kwargs)(cls)
        return cls

    return decorate
