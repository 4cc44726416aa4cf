"""Scripted solver of UnfoldShirt (tasks/cloth/unfold_shirt.py): the Panda lays the folded layers back one corner
at a time, the hem strip first, then each sleeve by its cuff, each corner carried in an arc over its crease to its
flat place (`shirt.flat_place`: where it lies when the shirt lies flat around its collar half as that lies now).

1. Hem: pinch each of the hem's two corners (lying upside down on the body) from above, fingers 4 cm apart
   closing across the corner's diagonal (`pinch`, as FoldTowelInHalf's corner pinch; tried again where it lies
   if it comes up empty), and carry it (`_carry`): lift `LIFT`, over the middle of its way `ARC_HEIGHT` high,
   lower to `RELEASE_ABOVE` over its flat place (read again there: the body slides under a carry), release,
   retreat.
2. Sleeves, left then right: carry the cuff's collar-end corner likewise; its hem-end corner too if the sleeve
   is not out yet.
3. Correct: while the task is not met and `CORRECT_STEPS` remain, carry the corner (of the six) furthest from its
   flat place again, at most `CORRECT_CARRIES` times.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import sapien

from maniladder_ms.deformables import shirt
from maniladder_ms.solvers import PlanningFailed, register_solver
from maniladder_ms.solvers.cloth.pinch import pinch
from maniladder_ms.solvers.panda import PRECISE_SETTLE_STEPS, PandaSolver
from maniladder_ms.tasks.cloth.unfold_shirt import UnfoldShirtEnv

LIFT = 0.05  # a cuff corner is first lifted this high, peeling the folded layer off the body
ARC_HEIGHT = 0.08  # then carried over the middle of its way this high
RELEASE_ABOVE = 0.01  # above the flat place (table level plus a radius), where the fingers open
PLACE_RETREAT = 0.06  # the hand rises this far once the fingers are open (`PandaSolver.place`'s default)
CORRECT_STEPS = 90  # a corrective carry starts only while this many steps of the horizon remain
CORRECT_CARRIES = 2


def _move(robot: PandaSolver, pose: sapien.Pose, settle_steps: int = 0):
    """`robot.move(pose, settle_steps)`, by an RRT path where mplib cannot time the straight (screw) one: its TOPP
    raised "Fail to parameterize path" planning the lift straight up from a pinched cuff on seed 187 (the arm had
    stopped on the folded layer); the dry-run plan raises before any step, so elsewhere the actions are the same."""
    try:
        robot.move(pose, settle_steps=settle_steps)
    except RuntimeError:
        plan = robot.planner.move_to_pose_with_RRTConnect(pose, dry_run=True)
        if plan == -1:
            raise PlanningFailed(f"no path to {pose}")
        robot.last = robot.planner.follow_path(plan)
        for _ in range(settle_steps):
            robot.hold_still()


def _goal(task: UnfoldShirtEnv, i: int) -> np.ndarray:
    """Particle `i`'s flat place (table level plus a radius), read now."""
    xy = shirt.flat_place(task.shirt.positions(), task.shirt.layout, [i])[0, 0].cpu().numpy()
    return np.array([xy[0], xy[1], task.cloth_config.radius])


def _carry(robot: PandaSolver, task: UnfoldShirtEnv, i: int, inner: int, rest_yaw: float) -> bool:
    """Pinch cuff particle `i`, lift it, carry it over the middle of its way `ARC_HEIGHT` high (if a straight
    path there exists) to `RELEASE_ABOVE` over its flat place, release, retreat."""
    pinched = pinch(robot, task.ee, task.shirt, i, inner, rest_yaw, move=partial(_move, robot))
    if pinched is None:
        return False
    grasp, yaw = pinched
    _move(robot, sapien.Pose([0, 0, LIFT]) * grasp)
    middle = (task.shirt.positions()[0, i].cpu().numpy() + _goal(task, i)) / 2
    apex = robot.top_down_pose([middle[0], middle[1], ARC_HEIGHT], yaw)
    if robot.planner.move_to_pose_with_screw(apex, dry_run=True) != -1:
        _move(robot, apex)
    release = robot.top_down_pose(_goal(task, i) + [0, 0, RELEASE_ABOVE], yaw)  # `robot.place`'s moves
    _move(robot, sapien.Pose([0, 0, LIFT]) * release)
    _move(robot, release, settle_steps=PRECISE_SETTLE_STEPS)
    robot.grip(closed=False)
    _move(robot, sapien.Pose([0, 0, PLACE_RETREAT]) * release)
    return True


def _with_inner(task: UnfoldShirtEnv, corner: int, dx: float, dy: float) -> tuple[int, int]:
    """(`corner`, its diagonal neighbour): the particle at rest offset (`dx`, `dy`) spacings from it."""
    rest = task.shirt.layout.positions
    target = rest[corner] + np.array([dx, dy, 0.0]) * shirt.spacing_of(task.shirt.layout)
    return corner, int(np.argmin(np.linalg.norm(rest - target, axis=1)))


def _hem_corners(task: UnfoldShirtEnv) -> list[tuple[int, int]]:
    """The hem's two corners (-y end, +y end), each with its diagonal neighbour inside the body."""
    hem = task.shirt.layout.named["hem"]  # -y to +y
    return [_with_inner(task, hem[0], 1, 1), _with_inner(task, hem[-1], 1, -1)]


def _cuff_corners(task: UnfoldShirtEnv, side: str) -> list[tuple[int, int]]:
    """The sleeve's two cuff corners, each with its diagonal neighbour inside the sleeve: (collar end, hem end)."""
    cuff = task.cuffs[side]  # hem to collar
    inward = -shirt.SIDE_SIGN[side]
    return [_with_inner(task, cuff[-1], -1, inward), _with_inner(task, cuff[0], 1, inward)]


@register_solver("UnfoldShirt")
def solve_unfold_shirt(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with PandaSolver.episode(env, seed) as robot:
        task: UnfoldShirtEnv = env.unwrapped
        rest_yaw = robot.current_yaw()  # grasp yaws within a quarter turn of it keep the last joint mid-range
        for corner in _hem_corners(task):
            _carry(robot, task, *corner, rest_yaw)
        for side in shirt.SIDES:
            for i, inner in _cuff_corners(task, side):
                if bool(task.evaluate()[f"{side}_sleeve_out"][0]):
                    break
                _carry(robot, task, i, inner, rest_yaw)
        horizon = task.task_spec.horizon
        for _ in range(CORRECT_CARRIES):
            if bool(task.evaluate()["success"][0]) or int(task.elapsed_steps[0]) > horizon - CORRECT_STEPS:
                break
            points = task.shirt.positions()[0, :, :2].cpu().numpy()
            corners = _hem_corners(task) + [c for side in shirt.SIDES for c in _cuff_corners(task, side)]
            worst = max(corners, key=lambda c: np.linalg.norm(points[c[0]] - _goal(task, c[0])[:2]))
            _carry(robot, task, *worst, rest_yaw)
        robot.hold_until_success()
        return robot.info
