"""Scripted solver of FlattenTowelCorner (tasks/cloth/flatten_towel_corner.py): the Panda pinches the folded corner
and lays it back at its flat place.

1. Line up above the folded corner particle, fingers closing across the way it will travel.
2. Pinch it `GRASP_ABOVE` over its centre, read again once the hand is above it (the folded layer settles into
   the sheet's hollows in the first steps).
3. Lift it `LIFT`, the fold peeling off the sheet behind it.
4. Carry it to its flat place, lower it to `RELEASE_HEIGHT` above, release, retreat `RETREAT_HEIGHT` up (`retreat`).
"""

from __future__ import annotations

import numpy as np
import sapien

from maniladder_ms.solvers import PlanningFailed, register_solver
from maniladder_ms.solvers.panda import PLANNED_APPROACH_HEIGHT, PRECISE_SETTLE_STEPS, PandaSolver
from maniladder_ms.tasks.cloth.flatten_towel_corner import FlattenTowelCornerEnv

GRASP_ABOVE = 0.006  # the TCP this far above the corner particle's centre: the pads pinch its sides, clear of the sheet
LIFT = 0.04  # the corner is carried this high, the fold peeling off the sheet behind it
RELEASE_HEIGHT = 0.005  # above the corner's flat place, where the fingers open
RETREAT_HEIGHT = 0.06  # above the release pose once the fingers are open (`PandaSolver.place`'s retreat)


def retreat(robot: PandaSolver, pose: sapien.Pose):
    """`robot.move(pose)`, by an RRT path where mplib cannot time the straight (screw) one: its TOPP raises
    "Fail to parameterize path" on the retreat above the released corner on seed 191 (the arm had stopped 13 mm
    above its release pose), once the towel was already flat; the dry-run plan raises before any step."""
    try:
        robot.move(pose)
    except RuntimeError:
        plan = robot.planner.move_to_pose_with_RRTConnect(pose, dry_run=True)
        if plan == -1:
            raise PlanningFailed(f"no path to {pose}")
        robot.last = robot.planner.follow_path(plan)


@register_solver("FlattenTowelCorner")
def solve_flatten_towel_corner(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with PandaSolver.episode(env, seed) as robot:
        task: FlattenTowelCornerEnv = env.unwrapped
        corner = task.corner_point()[0].cpu().numpy()
        goal = task.corner_goal()[0].cpu().numpy()
        way = goal[:2] - corner[:2]
        yaw = robot.closest_grasp_yaw(float(np.arctan2(way[1], way[0])) + np.pi / 2)
        robot.move(sapien.Pose([0, 0, PLANNED_APPROACH_HEIGHT]) * robot.top_down_pose(corner, yaw))
        grasp = robot.top_down_pose(task.corner_point()[0].cpu().numpy() + [0, 0, GRASP_ABOVE], yaw)
        robot.move(grasp, settle_steps=PRECISE_SETTLE_STEPS)
        robot.grip(closed=True)
        robot.move(sapien.Pose([0, 0, LIFT]) * grasp)
        release = robot.top_down_pose(task.corner_goal()[0].cpu().numpy() + [0, 0, RELEASE_HEIGHT], yaw)
        robot.move(sapien.Pose([0, 0, LIFT]) * release)
        robot.move(release, settle_steps=PRECISE_SETTLE_STEPS)
        robot.grip(closed=False)
        retreat(robot, sapien.Pose([0, 0, RETREAT_HEIGHT]) * release)
        robot.hold_until_success()
        return robot.info
