"""Scripted solver of PickPlacePen (tasks/rigid/pick_place_pen.py): a top-down pick of the pen at its centre and a
place along the tray's long side, planned with mplib.

1. Pick: grasp the pen at its centre from above, across its axis, and lift.
2. Turn: the grasp yaw turns by the angle between the pen's axis and the tray's long axis (the smaller way).
3. Place: lower into the tray over its centre along a straight path (the wrist yaw of the three equivalent half
   turns that has one), release, and hold until success.
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.geometry import actor_yaw
from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.panda import PLANNED_APPROACH_HEIGHT, PandaSolver
from maniladder_ms.tasks.rigid.pick_place_pen import PickPlacePenEnv

RELEASE_GAP = 0.01  # the pen's underside this far above the tray's base when the gripper opens


@register_solver("PickPlacePen")
def solve_pick_place_pen(env, seed: int) -> dict:
    """Grasp the pen at its centre from above, lift, turn it along the tray's long side, lower, release."""
    with PandaSolver.episode(env, seed) as robot:
        task: PickPlacePenEnv = env.unwrapped
        pen_p = task.pen.pose.p[0].cpu().numpy()
        pen_yaw = actor_yaw(task.pen)
        grasp_yaw = robot.closest_grasp_yaw(pen_yaw + np.pi / 2)
        robot.pick(robot.top_down_pose([pen_p[0], pen_p[1], task.pen_radius], grasp_yaw))
        # rotate the pen axis onto the tray's long axis: the grasp yaw follows by the same angle
        tray_p = task.tray.pose.p[0].cpu().numpy()
        tray_yaw = actor_yaw(task.tray)
        turn = (tray_yaw - pen_yaw + np.pi / 2) % np.pi - np.pi / 2
        release_z = task.tray_base_thickness + task.pen_radius + RELEASE_GAP
        # the pen lies the same way in the tray after a half turn: take whichever wrist yaw has a straight path
        above_tray = [tray_p[0], tray_p[1], release_z + PLANNED_APPROACH_HEIGHT]
        place_yaw = robot.straight_line_yaw(above_tray, [grasp_yaw + turn, grasp_yaw + turn - np.pi, grasp_yaw + turn + np.pi])
        robot.place(robot.top_down_pose([tray_p[0], tray_p[1], release_z], place_yaw))
        robot.hold_until_success()
        return robot.info
