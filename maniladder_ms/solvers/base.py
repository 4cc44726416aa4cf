"""What every motion solver shares (`PandaSolver`'s mplib plans, `DrivenSolver`'s closed loop): the episode
around a solver, the last step's info, and holding still until the task reports a settled success."""

from __future__ import annotations

from contextlib import contextmanager

import torch

from . import EPISODE_RESET_OPTIONS


class SolverBase:
    """A subclass is built as `cls(env)` after the reset, keeps the last `env.step` result in `last`
    (obs, reward, terminated, truncated, info) and says in `hold_still` how it steps without moving."""

    last = None

    @classmethod
    @contextmanager
    def episode(cls, env, seed: int):
        """Reset `env` with `seed` (EPISODE_RESET_OPTIONS: a freshly built scene) and yield a solver for it,
        closing it afterwards."""
        env.reset(seed=seed, options=dict(EPISODE_RESET_OPTIONS))
        solver = cls(env)
        try:
            yield solver
        finally:
            solver.close()

    def close(self):
        """Release what the solver holds (a planner); nothing by default."""

    @property
    def info(self) -> dict:
        """The last step's info dict ({} before the first step)."""
        return {} if self.last is None else self.last[-1]

    def hold_still(self):
        """One control step that keeps the robot where it is."""
        raise NotImplementedError

    def hold_until_success(self, max_steps: int = 30, stable_steps: int = 3):
        """Keep still until the task has reported success `stable_steps` steps in a row (or `max_steps`).

        Ending a demo in a settled success makes it robust for tools that replay it from recorded states
        (ManiSkill 3.0.1's replay_trajectory --use-env-states scores the last step one state behind).
        """
        streak = 0
        for _ in range(max_steps):
            streak = streak + 1 if bool(self.info.get("success", torch.zeros(1, dtype=torch.bool)).all()) else 0
            if streak >= stable_steps:
                return
            self.hold_still()
