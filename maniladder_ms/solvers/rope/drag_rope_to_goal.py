"""Scripted solver of DragRopeToGoal (tasks/rope/drag_rope_to_goal.py): grasp the rope's middle capsule with the
Panda and drag it, low, in a straight line to just past the zone centre, so both halves trail in behind it.

1. Grasp the middle capsule top-down, fingers across its axis, and lift it `DRAG_HEIGHT`.
2. Carry it to `LEAD` past the zone centre (on the line from the grasp through the centre), lower it to just
   above the table (`RELEASE_CLEARANCE`), release, retreat.
3. Hold still until success.
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.deformables import rope
from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.panda import PandaSolver
from maniladder_ms.tasks.rope.drag_rope_to_goal import DragRopeToGoalEnv

DRAG_HEIGHT = 0.04  # the grasped middle rides this high; both halves trail on the table
LEAD = 0.07  # the grasp ends this far past the zone centre, so the trailing halves end up centred
RELEASE_CLEARANCE = 0.005  # the grasped capsule is let go this far above its resting height


@register_solver("DragRopeToGoal")
def solve_drag_rope_to_goal(env, seed: int) -> dict:
    """Grasp the middle capsule across its axis, lift it 4 cm, drag it in a straight line to just past the
    zone centre (the halves trail behind into the zone), lower, release, retreat."""
    with PandaSolver.episode(env, seed) as robot:
        task: DragRopeToGoalEnv = env.unwrapped
        link = task.rope.links[task.grasp_segment]
        grip_at = link.pose.p[0].cpu().numpy()
        yaw = robot.closest_grasp_yaw(float(rope.segment_yaw(link.pose.q)[0]) + np.pi / 2)
        grasp = robot.top_down_pose([grip_at[0], grip_at[1], task.rope_config.radius], yaw)
        robot.pick(grasp, lift_height=DRAG_HEIGHT)
        zone = task.zone.pose.p[0].cpu().numpy()
        direction = zone[:2] - grip_at[:2]
        direction /= np.linalg.norm(direction)
        end = zone[:2] + LEAD * direction
        release = robot.top_down_pose([end[0], end[1], task.rope_config.radius + RELEASE_CLEARANCE], yaw)
        robot.place(release, approach_height=DRAG_HEIGHT)
        robot.hold_until_success()
        return robot.info
