"""Scripted solver of InsertPegBimanual (tasks/rigid/insert_peg/insert_peg_bimanual.py): the left arm lifts the
block by its handle and holds it still; the right arm picks the peg and inserts it, closed loop on the measured peg
and block.

1. Both arms reach at once: the left to the handle (top-down, fingers across it), the right to the peg's upper end
   (top-down, fingers across the two faces that will face the handle's sides).
2. Both close, then rise together: the block by BLOCK_LIFT, the peg by PEG_LIFT.
3. The left holds still while the right carries the peg over the hole, lines it up, goes down, opens and backs off
   (`insert_held_peg`, the family's phase).
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.solvers.rigid.insert_peg.phases import GRASP_BELOW_TOP, insert_held_peg
from maniladder_ms.tasks.rigid.insert_peg.insert_peg_bimanual import InsertPegBimanualEnv

BLOCK_LIFT = 0.1  # metres the left gripper raises the block
# of the two top-down hand yaws of a grasp, each arm takes the one nearest these: the left's wrist camera (on
# the hand's +x side) points away from the hole, and joint 7 stays clear of its limits all the way (the
# right's other choice ran it into +2.9 rad as it carried the peg to the left). The right's camera then faces
# the left hand: the 12 cm handle keeps the hands ~12.6 cm apart (at 8 cm they jammed in 6 of 6 seeds)
RIGHT_YAW = np.pi / 2
LEFT_YAW = np.pi / 2
PEG_LIFT = 0.2  # ... and the right one the peg: its lower end clears the raised block
RAISE_STEP = 0.015  # metres a control step both arms rise together


@register_solver("InsertPegBimanual", control_modes=TCP_DELTA_MODES)
def solve_insert_peg_bimanual(env, seed: int) -> dict:
    """Both arms reach at once: the left to the handle (top-down, fingers across it), the right to the
    peg's upper end (top-down, fingers across the two faces that will face the handle's sides); both close
    and rise together, the block by `BLOCK_LIFT`, the peg by `PEG_LIFT`; the left holds still while the
    right carries the peg over the hole, lines it up, goes down, opens and backs off (`insert_held_peg`,
    closed loop on the measured peg and block)."""
    with DrivenSolver.episode(env, seed) as s:
        task: InsertPegBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        block_yaw = yaw_of(task.block.pose.q)
        left_q = top_down_quat(DrivenSolver.neutral_yaw(block_yaw - LEFT_YAW, np.pi) + LEFT_YAW, n, device)
        # the right fingers close along the block's y (across the handle): its hand lies clear of the left's
        peg_yaw = yaw_of(task.peg.pose.q)
        face = block_yaw + torch.remainder(peg_yaw - block_yaw + np.pi / 4, np.pi / 2) - np.pi / 4
        right_q = top_down_quat(DrivenSolver.neutral_yaw(face - RIGHT_YAW, np.pi) + RIGHT_YAW, n, device)
        peg_grasp = task.peg.pose.p.clone()
        peg_grasp[:, 2] += task.peg_length / 2 - GRASP_BELOW_TOP
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        grasps = [Grasp("left_arm", "left_gripper", task.handle_point(), left_q, above),
                  Grasp("right_arm", "right_gripper", peg_grasp, right_q, above)]
        reach(s, grasps)
        grasp_together(s, ["left_gripper", "right_gripper"])
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        glide(s, {"left_arm": (grasps[0].p, grasps[0].p + BLOCK_LIFT * up, left_q),
                  "right_arm": (grasps[1].p, grasps[1].p + PEG_LIFT * up, right_q)}, step_length=RAISE_STEP,
              settle_steps=5)
        insert_held_peg(s, task, "right_arm", "right_gripper", "right")
        s.hold_until_success()
        return s.info
