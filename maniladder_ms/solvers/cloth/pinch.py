"""A Panda gripper's pinch of one cloth particle from above, the corner grasp of the cloth solvers that carry a
corner (FoldTowelInHalf's edges, UnfoldShirt's cuffs)."""

from __future__ import annotations

from typing import Callable, Optional

import numpy as np
import sapien

from maniladder_ms.solvers.panda import PLANNED_APPROACH_HEIGHT, PRECISE_SETTLE_STEPS, PandaSolver

GRASP_ABOVE = 0.003  # the TCP this far above the particle's centre: the pads pinch its sides, clear of the sheet
# the fingers open to a 4 cm gap before coming down (fully open, a finger lands on the particle's neighbours:
# test_ee_delta_gripper_picks_up_a_flat_towel_corner); the planner's gripper action, -1 closed .. 1 open
PINCH_OPENING = 0.2
GRASP_TRIES = 2  # a pinch that comes up empty is tried again from where the particle lies now


def pinch(robot: PandaSolver, ee, cloth, i: int, inner: int, rest_yaw: float,
          move: Optional[Callable[..., None]] = None) -> Optional[tuple[sapien.Pose, float]]:
    """Pinch `cloth`'s particle `i` from above with the end effector `ee`, fingers 4 cm apart closing across the
    line to particle `inner` (its diagonal neighbour), the last joint kept within a quarter turn of `rest_yaw`;
    `move(pose, settle_steps=...)` plans each motion (`robot.move` unless given). Returns the grasp pose and yaw,
    or None if the particle still is not held after GRASP_TRIES."""
    move = move or robot.move
    for _ in range(GRASP_TRIES):
        points = cloth.positions()[0].cpu().numpy()
        diagonal = points[inner, :2] - points[i, :2]
        yaw = float(np.arctan2(diagonal[1], diagonal[0])) + np.pi / 2
        yaw = rest_yaw + (yaw - rest_yaw + np.pi / 2) % np.pi - np.pi / 2  # the last joint kept mid-range
        move(sapien.Pose([0, 0, PLANNED_APPROACH_HEIGHT]) * robot.top_down_pose(points[i], yaw))
        robot.planner.open_gripper(t=4, gripper_state=PINCH_OPENING)
        grasp = robot.top_down_pose(cloth.positions()[0, i].cpu().numpy() + [0, 0, GRASP_ABOVE], yaw)
        move(grasp, settle_steps=PRECISE_SETTLE_STEPS)
        robot.grip(closed=True)
        if bool(ee.holds(cloth.spheres[i])[0]):
            return grasp, yaw
        robot.planner.open_gripper(t=4, gripper_state=PINCH_OPENING)
    return None
