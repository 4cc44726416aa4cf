"""Scripted solver of InsertTableLeg (tasks/rigid/insert_peg/insert_table_leg.py): the left arm lifts the table top
by its grip bar and holds it where it hangs; the right arm picks the leg and inserts it, closed loop on the measured
leg and top.

1. Both arms reach at once: the left to the grip bar (top-down, fingers across it), the right to the leg's upper
   end (top-down, fingers across the two faces that will face the grip bar's sides).
2. Both close, then rise together: the top by BLOCK_LIFT, the leg by PEG_LIFT (1-2, and those constants:
   `lift_block_and_peg`, the InsertPeg two-arm rows' phase).
3. The left holds still while the right carries the leg over the socket, lines it up with the socket's measured
   axis (turning the leg to the socket's walls the way that leaves the hand's yaw nearest RIGHT_YAW), goes down,
   opens and backs off (`insert_held_peg`, the InsertPeg family's phase).
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.rigid.insert_peg.phases import RIGHT_YAW, insert_held_peg, lift_block_and_peg
from maniladder_ms.tasks.rigid.insert_peg.insert_table_leg import InsertTableLegEnv

# the grasps, lift and hand yaws are the two-arm rows' (`lift_block_and_peg`: the top raised by BLOCK_LIFT, the
# leg by PEG_LIFT). The right also turns the leg to the socket's walls the way that ends its yaw nearest RIGHT_YAW
# (`prefer_yaw`): a leg standing ~45 degrees off the socket's walls, nudged past 45 by the grasp, was otherwise
# turned the other way, its hand to ~190 degrees, where the arm stopped 2 cm short of the socket's axis and the
# descent pushed the top down


@register_solver("InsertTableLeg", control_modes=TCP_DELTA_MODES)
def solve_insert_table_leg(env, seed: int) -> dict:
    """Both arms reach at once: the left to the grip bar (top-down, fingers across it), the right to the leg's
    upper end (top-down, fingers across the two faces that will face the grip bar's sides); both close and
    rise together, the top by `BLOCK_LIFT`, the leg by `PEG_LIFT` (`lift_block_and_peg`, phases.py); the left
    holds still while the right carries the leg over the socket, lines it up, goes down, opens and backs off
    (`insert_held_peg`, closed loop on the measured leg and top, turning the leg the way that leaves the
    hand's yaw nearest `RIGHT_YAW`)."""
    with DrivenSolver.episode(env, seed) as s:
        task: InsertTableLegEnv = env.unwrapped
        lift_block_and_peg(s, task)
        insert_held_peg(s, task, "right_arm", "right_gripper", "right", prefer_yaw=RIGHT_YAW)
        s.hold_until_success()
        return s.info
