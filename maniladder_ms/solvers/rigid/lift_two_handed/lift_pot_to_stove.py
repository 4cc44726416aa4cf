"""Scripted solver of LiftPotToStove (tasks/rigid/lift_two_handed/lift_pot_to_stove.py): both grippers take the
pot's handle tabs and carry it onto the stove plate in lock-step.

1. Each arm comes down top-down over its handle tab (`handle_centres`), fingers across it.
2. Both close and lift LIFT together.
3. Both carry the pot over the plate in lock-step.
4. Both lower it to SET_DOWN_GAP above the plate, open and rise (`top_down_carry`).
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import top_down_carry
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.lift_two_handed.lift_pot_to_stove import LiftPotToStoveEnv

LIFT = 0.08  # metres the handles rise: the pot's bottom clears the plate by ~7 cm
SET_DOWN_GAP = 0.004  # the pot's bottom this far above the plate when the grippers open


@register_solver("LiftPotToStove", control_modes=TCP_DELTA_MODES)
def solve_lift_pot_to_stove(env, seed: int) -> dict:
    """Phases 1-4 of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftPotToStoveEnv = env.unwrapped
        handles = task.handle_centres()
        across_tabs = yaw_of(task.pot.pose.q) - np.pi / 2  # the fingers close across the tabs
        to_plate = task.plate.pose.p - task.pot.pose.p
        top_down_carry(s, handles, across_tabs, LIFT, to_plate, task.plate_height + SET_DOWN_GAP)
        s.hold_until_success()
        return s.info
