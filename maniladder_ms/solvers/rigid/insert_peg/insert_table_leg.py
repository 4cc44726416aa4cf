"""Scripted solver of InsertTableLeg (tasks/rigid/insert_peg/insert_table_leg.py): the left arm lifts the table top
by its grip bar and holds it where it hangs; the right arm picks the leg and inserts it, closed loop on the measured
leg and top.

1. Both arms reach at once: the left to the grip bar (top-down, fingers across it), the right to the leg's upper
   end (top-down, fingers across the two faces that will face the grip bar's sides).
2. Both close, then rise together: the top by TOP_LIFT, the leg by LEG_LIFT.
3. The left holds still while the right carries the leg over the socket, lines it up with the socket's measured
   axis (turning the leg to the socket's walls the way that leaves the hand's yaw nearest RIGHT_YAW), goes down,
   opens and backs off (`insert_held_peg`, the InsertPeg family's phase).
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.solvers.rigid.insert_peg.phases import GRASP_BELOW_TOP, insert_held_peg
from maniladder_ms.tasks.rigid.insert_peg.insert_table_leg import InsertTableLegEnv

TOP_LIFT = 0.1  # metres the left gripper raises the top
# the hand yaws, as InsertPegBimanual's (the same arms and grip-bar direction): the left's wrist camera points
# away from the socket and the right's joint 7 stays clear of its limits as it carries the leg to the left. The
# right also turns the leg to the socket's walls the way that ends its yaw nearest RIGHT_YAW: a leg standing ~45
# degrees off the socket's walls, nudged past 45 by the grasp, was otherwise turned the other way, its hand to
# ~190 degrees, where the arm stopped 2 cm short of the socket's axis and the descent pushed the top down
RIGHT_YAW = np.pi / 2
LEFT_YAW = np.pi / 2
LEG_LIFT = 0.2  # ... and the right one the leg: its lower end clears the raised socket
RAISE_STEP = 0.015  # metres a control step both arms rise together


@register_solver("InsertTableLeg", control_modes=TCP_DELTA_MODES)
def solve_insert_table_leg(env, seed: int) -> dict:
    """Both arms reach at once: the left to the grip bar (top-down, fingers across it), the right to the leg's
    upper end (top-down, fingers across the two faces that will face the grip bar's sides); both close and
    rise together, the top by `TOP_LIFT`, the leg by `LEG_LIFT`; the left holds still while the right carries
    the leg over the socket, lines it up, goes down, opens and backs off (`insert_held_peg`, closed loop on
    the measured leg and top)."""
    with DrivenSolver.episode(env, seed) as s:
        task: InsertTableLegEnv = env.unwrapped
        n, device = task.num_envs, task.device
        top_yaw = yaw_of(task.block.pose.q)
        left_q = top_down_quat(DrivenSolver.neutral_yaw(top_yaw - LEFT_YAW, np.pi) + LEFT_YAW, n, device)
        leg_yaw = yaw_of(task.peg.pose.q)
        face = top_yaw + torch.remainder(leg_yaw - top_yaw + np.pi / 4, np.pi / 2) - np.pi / 4
        right_q = top_down_quat(DrivenSolver.neutral_yaw(face - RIGHT_YAW, np.pi) + RIGHT_YAW, n, device)
        leg_grasp = task.peg.pose.p.clone()
        leg_grasp[:, 2] += task.peg_length / 2 - GRASP_BELOW_TOP
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        grasps = [Grasp("left_arm", "left_gripper", task.handle_point(), left_q, above),
                  Grasp("right_arm", "right_gripper", leg_grasp, right_q, above)]
        reach(s, grasps)
        grasp_together(s, ["left_gripper", "right_gripper"])
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        glide(s, {"left_arm": (grasps[0].p, grasps[0].p + TOP_LIFT * up, left_q),
                  "right_arm": (grasps[1].p, grasps[1].p + LEG_LIFT * up, right_q)}, step_length=RAISE_STEP,
              settle_steps=5)
        insert_held_peg(s, task, "right_arm", "right_gripper", "right", prefer_yaw=RIGHT_YAW)
        s.hold_until_success()
        return s.info
