"""Scripted demo solvers: the registry, and per-embodiment motion helpers.

Each task's solver lives beside the task (in its module under `maniladder_ms/tasks/`) and registers
itself here with `@register_solver(<task id>)`; `solve(env, seed)` finds and runs it.
"""

from __future__ import annotations

from typing import Callable

SOLVERS: dict[str, Callable] = {}


class PlanningFailed(RuntimeError):
    """A solver's planner found no path to a requested pose: the episode fails, it is not a bug."""


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


def solve_within_horizon(env, seed: int) -> dict:
    """{success, steps} of one solver episode: success only if reached within the task's horizon."""
    try:
        info = solve(env, seed)
        steps = int(info["elapsed_steps"][0])
        success = bool(info["success"][0]) and steps <= env.unwrapped.task_spec.horizon
    except PlanningFailed:
        steps, success = int(env.unwrapped.elapsed_steps[0]), False
    return dict(success=success, steps=steps)


def sweep(task_id: str, seeds, progress: bool = False, **make_kwargs) -> list[dict]:
    """Run the task's solver on each seed in one env; rows of {seed, success, steps}.

    An episode counts as a success only if it succeeds within the task's horizon.
    """
    import maniladder_ms
    from tqdm import tqdm

    make_kwargs.setdefault("obs_mode", "state")
    env = maniladder_ms.make(task_id, control_mode="pd_joint_pos", **make_kwargs)
    try:
        rows = [dict(seed=seed, **solve_within_horizon(env, seed))
                for seed in tqdm(list(seeds), desc=f"{task_id} solver", disable=not progress)]
    finally:
        env.close()
    return rows
