"""Scripted solver of InsertPegInHole (tasks/rigid/insert_peg/insert_peg_in_hole.py): pick the standing peg by its
upper end and insert it into the fixed block's hole, closed loop on the measured peg in the hand.

1. Grasp the peg's upper end from above (GRASP_BELOW_TOP below its top), fingers across two faces; lift.
2. Carry it upright over the hole, its faces along the hole's walls; line it up over the opening; go down; open;
   back off upwards (`insert_held_peg`, the family's phase).
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.rigid.insert_peg.phases import GRASP_BELOW_TOP, insert_held_peg
from maniladder_ms.tasks.rigid.insert_peg.insert_peg_in_hole import InsertPegInHoleEnv

PEG_LIFT = 0.1  # metres the peg is lifted off the table before the carry

@register_solver("InsertPegInHole", control_modes=TCP_DELTA_MODES)
def solve_insert_peg_in_hole(env, seed: int) -> dict:
    """Grasp the peg's upper end from above, fingers across two faces; lift; carry it upright over the hole,
    its faces turned along the hole's walls, line it up over the opening, go down, open, back off upwards
    (`insert_held_peg`, closed loop on the measured peg in the hand)."""
    with DrivenSolver.episode(env, seed) as s:
        task: InsertPegInHoleEnv = env.unwrapped
        yaw = DrivenSolver.neutral_yaw(yaw_of(task.peg.pose.q), np.pi / 2)
        grasp_p = task.peg.pose.p.clone()
        grasp_p[:, 2] += task.peg_length / 2 - GRASP_BELOW_TOP
        s.pick("arm", "gripper", grasp_p, yaw, lift=PEG_LIFT)
        insert_held_peg(s, task, "arm", "gripper", None)
        s.hold_until_success()
        return s.info
