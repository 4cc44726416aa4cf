"""Scripted solver of InsertPegBimanual (tasks/rigid/insert_peg/insert_peg_bimanual.py): the left arm lifts the
block by its handle and holds it still; the right arm picks the peg and inserts it, closed loop on the measured peg
and block.

1. Both arms reach at once: the left to the handle (top-down, fingers across it), the right to the peg's upper end
   (top-down, fingers across the two faces that will face the handle's sides).
2. Both close, then rise together: the block by BLOCK_LIFT, the peg by PEG_LIFT (1-2, and those constants:
   `lift_block_and_peg`, the two-arm rows' phase in phases.py).
3. The left holds still while the right carries the peg over the hole, lines it up, goes down, opens and backs off
   (`insert_held_peg`, the family's phase).
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.rigid.insert_peg.phases import insert_held_peg, lift_block_and_peg
from maniladder_ms.tasks.rigid.insert_peg.insert_peg_bimanual import InsertPegBimanualEnv


@register_solver("InsertPegBimanual", control_modes=TCP_DELTA_MODES)
def solve_insert_peg_bimanual(env, seed: int) -> dict:
    """Both arms reach at once: the left to the handle (top-down, fingers across it), the right to the
    peg's upper end (top-down, fingers across the two faces that will face the handle's sides); both close
    and rise together, the block by `BLOCK_LIFT`, the peg by `PEG_LIFT` (`lift_block_and_peg`, phases.py);
    the left holds still while the right carries the peg over the hole, lines it up, goes down, opens and
    backs off (`insert_held_peg`, closed loop on the measured peg and block)."""
    with DrivenSolver.episode(env, seed) as s:
        task: InsertPegBimanualEnv = env.unwrapped
        lift_block_and_peg(s, task)
        insert_held_peg(s, task, "right_arm", "right_gripper", "right")
        s.hold_until_success()
        return s.info
