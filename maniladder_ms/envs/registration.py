"""Registering ManiLadder tasks in ManiSkill's (and gymnasium's) env registry from the catalog.

Registration is lazy: `maniladder_ms.tasks` finds every task's module by its `@register_task("<TaskId>")` line
without importing it and calls `register_lazy`, which puts a `LazyEnvSpec` in ManiSkill's `REGISTERED_ENVS`
and the same entry point as ManiSkill's `register_env` in gymnasium's registry. The module is imported on
first use of the spec's `cls` (`gym.make`, `maniladder_ms.make`, `REGISTERED_ENVS[env_id].cls`); its
`@register_task` then hands the class to the spec.
"""

from __future__ import annotations

import importlib
from copy import deepcopy
from functools import partial

import gymnasium as gym
from gymnasium.envs.registration import WrapperSpec
from mani_skill.utils import assets
from mani_skill.utils.registration import REGISTERED_ENVS, EnvSpec, make, make_vec, register_env

from maniladder_ms.catalog import default_catalog


class TaskImportError(ImportError):
    """A task module could not be imported (or did not register its task): only its tasks are affected."""


class LazyEnvSpec(EnvSpec):
    """ManiSkill's EnvSpec whose env class is imported from `module` on first use."""

    def __init__(self, uid: str, task_id: str, module: str, path: str, max_episode_steps=None,
                 default_kwargs: dict | None = None, error: str | None = None):
        self._cls = None
        self.task_id, self.module, self.path, self.error = task_id, module, path, error
        super().__init__(uid, None, max_episode_steps=max_episode_steps, default_kwargs=default_kwargs)

    @property
    def cls(self):
        if self._cls is None:
            import_task_module(self.task_id, self.module, self.path, self.error)
            if self._cls is None:
                raise TaskImportError(f"{self.path} was imported but registered no env for task {self.task_id} "
                                      f"(its @register_task({self.task_id!r}) line is not on a class?)")
        return self._cls

    @cls.setter
    def cls(self, value):
        self._cls = value

    def resolve(self, cls, default_kwargs: dict):
        """The module's `@register_task` ran: the class, and any default kwargs the decorator adds."""
        self._cls = cls
        self.default_kwargs.update(deepcopy(default_kwargs))
        gym.registry[self.uid].kwargs.update(deepcopy(default_kwargs))

    def make(self, **kwargs):
        self.cls  # import first: the decorator may add default kwargs
        return super().make(**kwargs)


def import_task_module(task_id: str, module: str, path: str, error: str | None = None):
    """Import a task's module; any failure is a `TaskImportError` naming the task and the file."""
    if error:
        raise TaskImportError(f"task {task_id}: {error}")
    try:
        importlib.import_module(module)
    except Exception as e:
        raise TaskImportError(f"task {task_id}: importing {path} failed: {type(e).__name__}: {e}") from e


def register_lazy(task_id: str, module: str, path: str, error: str | None = None):
    """Register `ManiLadder-<task_id>-v1` (ManiSkill's registry and gymnasium's, as ManiSkill's `register_env`
    does) with the env class to be imported from `module` (file `path`) on first use."""
    spec = default_catalog().get(task_id)
    kwargs = {"task_id": task_id}
    REGISTERED_ENVS[spec.env_id] = LazyEnvSpec(spec.env_id, task_id, module, path, max_episode_steps=spec.horizon,
                                               default_kwargs=deepcopy(kwargs), error=error)
    assets.DATA_GROUPS[spec.env_id] = []
    gym.register(
        spec.env_id,
        entry_point=partial(make, env_id=spec.env_id),
        vector_entry_point=partial(make_vec, env_id=spec.env_id),
        max_episode_steps=spec.horizon,
        disable_env_checker=True,
        kwargs=deepcopy(kwargs),
        additional_wrappers=[
            WrapperSpec("MSTimeLimit", entry_point="mani_skill.utils.registration:TimeLimitWrapper",
                        kwargs=dict(max_episode_steps=spec.horizon))
        ],
    )


def _refuse_unbuilt(task_id: str, **kwargs):
    import maniladder_ms

    spec = default_catalog().get(task_id)
    raise maniladder_ms.TaskNotImplementedError(
        f"{spec.env_id}: task {spec.id} ({spec.suite}) is in the catalog but not implemented yet; "
        "`maniladder list --implemented` shows the ones that are")


def register_unbuilt(task_id: str):
    """Put a catalog task that no module builds yet in gymnasium's registry only, with an entry point that
    raises `TaskNotImplementedError`: `gym.make` then says "not implemented yet" rather than suggesting
    another task. ManiSkill's `REGISTERED_ENVS` (what `TaskSpec.implemented` reads) does not get it."""
    spec = default_catalog().get(task_id)
    gym.register(spec.env_id, entry_point=partial(_refuse_unbuilt, task_id), disable_env_checker=True)


# task ids registered by a module's import rather than found by the scan (tests/test_registry.py: none)
UNSCANNED: set[str] = set()


def register_task(task_id: str, **default_kwargs):
    """Class decorator: register `ManiLadder-<task_id>-v1` with the catalog's horizon as max_episode_steps.

    Stack several on one class for a family that differs by parameters (e.g. number of blocks). Write it
    at the start of a line with the task id as a string literal: `maniladder_ms.tasks` finds it there.
    """
    spec = default_catalog().get(task_id)

    def decorate(cls):
        lazy = REGISTERED_ENVS.get(spec.env_id)
        if isinstance(lazy, LazyEnvSpec):
            lazy.resolve(cls, default_kwargs)
        else:
            UNSCANNED.add(task_id)
            register_env(spec.env_id, max_episode_steps=spec.horizon, task_id=task_id, **default_kwargs)(cls)
        return cls

    return decorate
