"""Scripted solver of TwistOpenBottleHands (tasks/articulated/unscrew_cap/twist_open_bottle_hands.py): the left LEAP
hand holds the free bottle in OpenJarHands' side grasp with its palm on the body while the right LEAP hand twists
the small cap off in rim-pinch strokes.

1. From the ready pose the holding hand preshapes and comes down to its line-up point beside the bottle while the
   twisting hand rises above the cap winding its wrist up (`phases.wind_up_above_lid`).
2. The holding hand moves in and closes round the bottle's body.
3. Twist strokes with the twisting hand (`solvers.twist.unscrew`): pinch the cap's rim from above, turn the wrist
   counter-clockwise about the cap's measured axis with the TCP held in place (an integral term), open to the rim
   preshape with the arm still, rise, turn back, pinch again, until the cap is off its thread (three strokes).
4. Hold until success.
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver

from .open_jar_hands import hold_and_twist

# the holding grasp, the rim grasp and the strokes' timing are OpenJarHands' (`open_jar_hands.hold_and_twist`: the
# same 6 cm x 16 cm body, the same hands); the cap is lower in the rim grasp and needs more strokes
RIM_OFFSET = (-0.0205, 0.007, 0.033)  # the cap's mid-height centre in the TCP frame where the rim grasp closes
# the rim grasp turns the cap by ~0.9 of the wrist's turn (seed 100: 5.18 rad for 5.6 rad of joint 7 in the first
# stroke), not the power grasp's `phases.FOLLOW`: the open hand turns back for the rest of the turn over this, plus
# BACK_MARGIN rad (a regrasp on a cap off its home stop turns it back a little as the hand closes)
RIM_FOLLOW = 0.9
BACK_MARGIN = 0.8
MAX_STROKES = 5


@register_solver("TwistOpenBottleHands", control_modes=TCP_DELTA_MODES)
def solve_twist_open_bottle_hands(env, seed: int) -> dict:
    """Left: side grasp on the bottle's body from the ready pose; right: rise, wind the wrist up above the cap,
    then rim-grasp twist strokes until the cap is off."""
    return hold_and_twist(env, seed, RIM_OFFSET, max_strokes=MAX_STROKES, follow=RIM_FOLLOW, back_margin=BACK_MARGIN)
