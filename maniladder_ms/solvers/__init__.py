"""Scripted demo solvers: the registry, and per-embodiment motion helpers.

Each task's solver lives beside the task (in its module under `maniladder_ms/tasks/`) and registers
itself here with `@register_solver(<task id>)`; `solve(env, seed)` finds and runs it.
"""

from __future__ import annotations

from typing import Callable

SOLVERS: dict[str, Callable] = {}


def register_solver(*task_ids: str):
    def decorate(fn):
        for task_id in task_ids:
            SOLVERS[task_id] = fn
        return fn

    return decorate


def solve(env, seed: int) -> dict:
    """Reset `env` with `seed` and run its task's scripted solver; returns the final step's info dict."""
    task_id = env.unwrapped.task_spec.id
    if task_id not in SOLVERS:
        raise KeyError(f"no scripted solver registered for task {task_id}")
    return SOLVERS[task_id](env, seed)
