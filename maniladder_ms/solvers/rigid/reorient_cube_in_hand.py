"""Scripted solver of ReorientCubeInHand (tasks/rigid/reorient_cube_in_hand.py): the palm-up LEAP hand tips the cube
lying on its finger bases a quarter turn over towards the heel with its fingers, then curls them over it. The arm
holds its ready pose throughout: the turn is the fingers' alone.

1. Tip: the three fingers rise at their knuckles ("roll_tip", over `TIP_STEPS`): they lift the cube's fingertip
   side, it pivots on its bottom edge nearest the heel, past its balance point, and falls onto the palm with the
   marked face (which pointed along the fingers) on top.
2. Grip: the fingers curl on over the cube ("roll_grip", over `GRIP_STEPS`), pressing it onto the palm; hold until
   success.
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver

# control steps over which the knuckles rise to "roll_tip" (1 s; the cube tips as the knuckles pass ~1 rad, falls
# onto the palm and settles before the ramp ends: 50/50 on seeds 100-149, the only value run)
TIP_STEPS = 20
GRIP_STEPS = 20  # control steps over which the fingers curl to "roll_grip" (the close_hand ramp's 2 s halved, as above)
GRIP_HOLD_STEPS = 5  # steps held at "roll_grip" before waiting for success


@register_solver("ReorientCubeInHand", control_modes=TCP_DELTA_MODES)
def solve_reorient_cube_in_hand(env, seed: int) -> dict:
    """Tip the cube over the palm's heel with the knuckles, then curl the fingers over it."""
    with DrivenSolver.episode(env, seed) as s:
        s.close_hand("hand", "roll_tip", ramp_steps=TIP_STEPS, hold_steps=0)
        s.close_hand("hand", "roll_grip", ramp_steps=GRIP_STEPS, hold_steps=GRIP_HOLD_STEPS)
        s.hold_until_success()
        return s.info
