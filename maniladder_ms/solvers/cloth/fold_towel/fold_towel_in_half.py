"""Scripted solver of FoldTowelInHalf (tasks/cloth/fold_towel/fold_towel_in_half.py): the Panda lays the short edge
further from the robot onto the near one, one corner at a time, each carried in an arc over the fold line.

1. Pinch the far edge's first corner from above (`pinch`: fingers 4 cm apart closing across the towel's
   diagonal, as FlattenTowelCorner; tried again where it lies if it comes up empty).
2. Carry it (`_carry`): lift `LIFT`, over the middle of its way `ARC_HEIGHT` high, lower to `RELEASE_ABOVE`
   over its partner corner (read again there), release, retreat.
3. The far edge's other corner likewise, read again where the first carry left it.
4. Correct: while the fold error is above `CORRECT_SHARE` of the tolerance and `CORRECT_STEPS` remain, carry the
   corner furthest from its partner again, low (`CORRECT_LIFT`, no arc).
"""

from __future__ import annotations

import numpy as np
import sapien

from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.cloth.pinch import pinch
from maniladder_ms.solvers.panda import PandaSolver
from maniladder_ms.tasks.cloth.fold_towel.fold_towel_in_half import FoldTowelInHalfEnv

LIFT = 0.05  # a corner is first lifted this high
ARC_HEIGHT = 0.11  # then carried over the middle of its way this high (about half the towel's half-length)
RELEASE_ABOVE = 0.02  # above the partner corner, where the fingers open: one layer's thickness
# after both corners: if the mean pair distance is above CORRECT_SHARE of the task's tolerance, the corner
# furthest from its partner is carried again (low, no arc), while the episode has CORRECT_STEPS steps left
CORRECT_SHARE, CORRECT_LIFT, CORRECT_STEPS = 0.75, 0.03, 75


def _carry(robot: PandaSolver, task: FoldTowelInHalfEnv, i: int, inner: int, j: int, rest_yaw: float,
           arc_height: float, lift: float) -> bool:
    """Pinch particle `i`, lift it `lift`, carry it over the middle of its way `arc_height` high (if a
    straight path there exists: an RRT path may swing the held towel through the air) to one layer above
    particle `j` (read again there: the carry drags the sheet), release, retreat."""
    pinched = pinch(robot, task.ee, task.towel, i, inner, rest_yaw)
    if pinched is None:
        return False
    grasp, yaw = pinched
    robot.move(sapien.Pose([0, 0, lift]) * grasp)
    if arc_height > lift:
        middle = (task.towel.positions()[0, i] + task.towel.positions()[0, j]).cpu().numpy() / 2
        apex = robot.top_down_pose([middle[0], middle[1], arc_height], yaw)
        if robot.planner.move_to_pose_with_screw(apex, dry_run=True) != -1:
            robot.move(apex)
    partner = task.towel.positions()[0, j].cpu().numpy()
    robot.place(robot.top_down_pose(partner + [0, 0, RELEASE_ABOVE], yaw), approach_height=lift)
    return True


@register_solver("FoldTowelInHalf")
def solve_fold_towel_in_half(env, seed: int) -> dict:
    """The phases of the module docstring; a corner that cannot be pinched is replaced by its neighbour along
    the edge (with that neighbour's partner)."""
    with PandaSolver.episode(env, seed) as robot:
        task: FoldTowelInHalfEnv = env.unwrapped
        rows, cols = task.GRID
        index = np.arange(rows * cols).reshape(rows, cols)
        points = task.towel.positions()[0].cpu().numpy()
        far_row = 0 if points[index[0], 0].mean() > points[index[-1], 0].mean() else rows - 1
        near_row, inward = rows - 1 - far_row, (1 if far_row == 0 else -1)
        rest_yaw = robot.current_yaw()  # grasp yaws within a quarter turn of it keep the last joint mid-range
        # (corner, its diagonal neighbour, its partner) per column; the corner's neighbour along the edge
        # (with the particle inwards of the corner, and its partner) in case the corner cannot be pinched
        step = {0: 1, cols - 1: -1}
        corners = [(index[far_row, c], index[far_row + inward, c + step[c]], index[near_row, c]) for c in step]
        backups = [(index[far_row, c + step[c]], index[far_row + inward, c], index[near_row, c + step[c]])
                   for c in step]
        for corner, backup in zip(corners, backups):
            if not _carry(robot, task, *corner, rest_yaw, ARC_HEIGHT, LIFT):
                _carry(robot, task, *backup, rest_yaw, ARC_HEIGHT, LIFT)
        horizon = task.task_spec.horizon
        for _ in range(2):  # the mean pair distance over CORRECT_SHARE of the tolerance: lay the worse corner again
            folded = task.fold_error()[0] <= CORRECT_SHARE * task.fold_tol
            if folded or int(task.elapsed_steps[0]) > horizon - CORRECT_STEPS:
                break
            points = task.towel.positions()[0].cpu().numpy()
            worst = int(np.argmax([np.linalg.norm(points[i, :2] - points[j, :2]) for i, _, j in corners]))
            _carry(robot, task, *corners[worst], rest_yaw, 0.0, CORRECT_LIFT)
        robot.hold_until_success()
        return robot.info
