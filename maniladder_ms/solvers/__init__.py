"""Scripted demo solvers: the registry, the control layer (`panda`, `driven`, `bimanual`, ...) and, in a tree
that mirrors `maniladder_ms/tasks/`, one module per task's solver (`rigid/pick_place_pen.py` solves the task of
`tasks/rigid/pick_place_pen.py`; a family's shared phases sit in its package's `phases.py`).

A task's solver registers itself with `@register_solver("<TaskId>", control_modes=...)` written at the start of
a line; the solver tree is scanned for those lines (no import), so `find_solver` imports only the module of the
task asked for. `solve(env, seed)` finds and runs it.

A solver drives the env in one of the control modes it was registered with: mplib solvers
(`solvers.panda`) command joint targets that `JointTargetAdapter` re-expresses in any of
`JOINT_TARGET_MODES`; closed-loop TCP solvers (`solvers.driven`, hands and dual arms) run in
`pd_ee_delta_pose` only. The first mode is the solver's own: sweeps and evaluation use it.
"""

from __future__ import annotations

import importlib
import importlib.resources
import re
from dataclasses import dataclass
from typing import Callable

JOINT_TARGET_MODES = ("pd_joint_pos", "pd_joint_delta_pos", "pd_ee_delta_pose")
TCP_DELTA_MODES = ("pd_ee_delta_pose",)


@dataclass(frozen=True)
class Solver:
    run: Callable  # (env, seed) -> info dict of the last step
    control_modes: tuple[str, ...]

    @property
    def control_mode(self) -> str:
        return self.control_modes[0]


SOLVERS: dict[str, Solver] = {}

# Solver episodes start from a freshly built scene (as every seeded reset of a ManiLadder env does, see
# `ManiLadderEnv`'s `fresh_physics_per_seed`); the option is passed explicitly too, so that the reset kwargs a
# demo records say so, and a replay (`demos verify`, ManiSkill's replay_trajectory, which reset with the
# recorded options) rebuilds the scene whatever the env's setting.
EPISODE_RESET_OPTIONS = {"reconfigure": True}


class PlanningFailed(RuntimeError):
    """A solver's planner found no path to a requested pose: the episode fails, it is not a bug."""


def register_solver(*task_ids: str, control_modes: tuple[str, ...] = JOINT_TARGET_MODES):
    def decorate(fn):
        for task_id in task_ids:
            SOLVERS[task_id] = Solver(fn, tuple(control_modes))
        return fn

    return decorate


# the decorator at the start of a line with the task id as a string literal (as tasks' @register_task)
SOLVER_LINE = re.compile(r"""^@register_solver\(\s*["']([A-Za-z0-9_]+)["']""", re.MULTILINE)


def solver_files() -> dict[str, str]:
    """{task id: solver module path relative to this package ('rigid/pick_place_pen.py')}, by a text scan of
    the per-task solver tree (this package's sub-folders)."""
    from maniladder_ms.tasks import module_files

    root = importlib.resources.files(__name__)
    found = {}
    for entry in sorted(root.iterdir(), key=lambda e: e.name):
        if not entry.is_dir() or entry.name.startswith(("_", ".")):
            continue
        for name in module_files(entry, f"{entry.name}/"):
            for task_id in SOLVER_LINE.findall(root.joinpath(name).read_text(encoding="utf-8")):
                found.setdefault(task_id, name)
    return found


def solver_module(task_id: str) -> str | None:
    """The dotted name of the module that registers `task_id`'s solver, or None if none does."""
    name = solver_files().get(task_id)
    return f"{__name__}.{name[:-3].replace('/', '.')}" if name else None


def find_solver(task_id: str) -> Solver | None:
    """The task's solver, importing its solver module first; None if the task has none."""
    if task_id not in SOLVERS:
        module = solver_module(task_id)
        if module is not None:
            importlib.import_module(module)
    return SOLVERS.get(task_id)


def solver_for(task_id: str) -> Solver:
    solver = find_solver(task_id)
    if solver is None:
        raise KeyError(f"no scripted solver registered for task {task_id}")
    return solver


def solve(env, seed: int) -> dict:
    """Reset `env` with `seed` and run its task's scripted solver; returns the final step's info dict."""
    solver = solver_for(env.unwrapped.task_spec.id)
    mode = env.unwrapped.control_mode
    if mode not in solver.control_modes:
        raise ValueError(f"the {env.unwrapped.task_spec.id} solver drives {', '.join(solver.control_modes)}; "
                         f"the env is in {mode!r}")
    return solver.run(env, seed)


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
    make_kwargs.setdefault("control_mode", solver_for(task_id).control_mode)
    env = maniladder_ms.make(task_id, **make_kwargs)
    try:
        rows = [dict(seed=seed, **solve_within_horizon(env, seed))
                for seed in tqdm(list(seeds), desc=f"{task_id} solver", disable=not progress)]
    finally:
        env.close()
    return rows
