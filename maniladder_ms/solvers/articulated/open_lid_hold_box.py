"""Scripted solver of OpenLidHoldBox (tasks/articulated/open_lid_hold_box.py): the left gripper holds the box by
its hinge end while the right lifts the lid open by its lip.

1. The left gripper lines up `LINE_UP_DISTANCE` beyond the box's hinge end, moves straight in (`bimanual.reach`)
   to the task's holding grasp (`OpenLidHoldBoxEnv.holding_grasp`) and closes across the box.
2. The right gripper opens the lid (`solvers.lids.open_lid`): hooks the fingers under the lip and swings the lid
   past vertical, the left holding on.
3. Hold until success.
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, reach
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.lids import open_lid
from maniladder_ms.tasks.articulated.open_lid_hold_box import OpenLidHoldBoxEnv

LINE_UP_DISTANCE = 0.1  # m beyond the box's hinge end where the holding gripper lines up


@register_solver("OpenLidHoldBox", control_modes=TCP_DELTA_MODES)
def solve_open_lid_hold_box(env, seed: int) -> dict:
    """Left: sideways grasp across the box's hinge (left) end, below the lid; right: lift the lid by its
    lip past vertical while the left keeps holding."""
    with DrivenSolver.episode(env, seed) as s:
        task: OpenLidHoldBoxEnv = env.unwrapped
        p, q, outward = task.holding_grasp()
        reach(s, [Grasp("left_arm", "left_gripper", p, q, LINE_UP_DISTANCE * outward)])
        s.grasp("left_gripper")
        open_lid(s, "right_arm", "right_gripper", task.box, task.box_shape)
        s.hold_until_success()
        return s.info
