"""Scripted solver of PlaceMugOnCoasterHand (tasks/rigid/place_mug_on_coaster_hand.py): the LEAP hand's mug phases
of `solvers.mug.mug_to_coaster`, shared with HandoverMugHands' regrasp (TCP deltas).

1. Grasp: top-down power grasp on the mug's body with the handle along the finger row (to the index or the ring
   finger's side, whichever keeps the wrist nearer its rest yaw).
2. Lift, and straighten the mug in the grip.
3. Carry it over the coaster and straighten it again.
4. Set down: lower it onto the coaster closed loop (the TCP target follows where the mug is).
5. Release: relax the grip, open the fingers, then the thumb, and rise; hold until success.
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.mug import mug_to_coaster
from maniladder_ms.tasks.rigid.place_mug_on_coaster_hand import PlaceMugOnCoasterHandEnv


@register_solver("PlaceMugOnCoasterHand", control_modes=TCP_DELTA_MODES)
def solve_place_mug_on_coaster_hand(env, seed: int) -> dict:
    """Top-down power grasp on the mug's body with the handle along the finger row (to the index or the ring
    finger's side, whichever keeps the wrist nearer its rest yaw), lift, straighten the mug in the grip, carry it
    over the coaster, straighten again, lower it onto the coaster closed loop (the TCP target follows where the mug
    is), relax the grip, open the fingers, then the thumb, and rise (`mug_to_coaster`)."""
    with DrivenSolver.episode(env, seed) as s:
        task: PlaceMugOnCoasterHandEnv = env.unwrapped
        mug_to_coaster(s, task)
        s.hold_until_success()
        return s.info
