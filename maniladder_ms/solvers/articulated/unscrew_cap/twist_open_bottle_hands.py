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

import numpy as np

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import close_hands
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import is_wound_up, unscrew
from maniladder_ms.tasks.articulated.unscrew_cap.twist_open_bottle_hands import (HOLDER, TWISTER,
                                                                                 TwistOpenBottleHandsEnv)
from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.solvers.side_grasps import LINE_UP_ABOVE, SIDE_PRESHAPE_STEPS, lined_up_side_grasp

from .phases import WIND_UP_STEPS, wind_up_above_lid

# The holding hand's side grasp on the bottle's body: OpenJarHands' (the same 6 cm x 16 cm body), 8 cm up
HOLD_GRASP = dict(yaw=-np.pi / 2, pitch=0.0, up=-1.0, height=0.08, shift=0.04, inwards=0.045,
                  approach="preshape", close=LEAP_SYNERGIES["side_power_ring_open"])
READY_POS_TOL = 0.01  # m: both arms are at their targets
MOVE_IN_STEPS, MOVE_IN_POS_TOL = 40, 0.003
HOLD_CLOSE_STEPS = 20  # control steps the holding hand closes over

RIM_OPEN = LEAP_SYNERGIES["rim_open"]
RIM_CLOSE = LEAP_SYNERGIES["rim_close"]
RIM_OFFSET = (-0.0205, 0.007, 0.033)  # the cap's mid-height centre in the TCP frame where the rim grasp closes
RAMP_STEPS = 40  # control steps the rim grasp closes over (the held bottle gives)
HOLD_GAIN = 0.3  # the TCP position integral's gain (`twist.HoldPosition`), OpenJarHands'
RISE_BACK = 0.08  # m above the cap top where the opened hand turns back between strokes
RELEASE_STEPS = 15  # control steps the hand opens over between strokes, the arm held still
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
    with DrivenSolver.episode(env, seed) as s:
        task: TwistOpenBottleHandsEnv = env.unwrapped
        hold, _ = lined_up_side_grasp(f"{HOLDER}_arm", f"{HOLDER}_hand", task.jar.pose.p, HOLD_GRASP)
        twist_arm = f"{TWISTER}_arm"
        s.set_ee(hold.ee, HOLD_GRASP["approach"], steps=0)
        for k in range(WIND_UP_STEPS):
            target = (s.above(hold.lined_up[0], LINE_UP_ABOVE), hold.q) if k < SIDE_PRESHAPE_STEPS else hold.lined_up
            errs = s.step({hold.arm: target, twist_arm: wind_up_above_lid(s, task, twist_arm, RIM_OFFSET)})
            ep, _ = errs[twist_arm]
            hp, _ = errs[hold.arm]
            if (k >= SIDE_PRESHAPE_STEPS and bool((ep < READY_POS_TOL).all() and (hp < READY_POS_TOL).all())
                    and is_wound_up(s, twist_arm)):
                break
        s.move({hold.arm: (hold.p, hold.q)}, max_steps=MOVE_IN_STEPS, pos_tol=MOVE_IN_POS_TOL)
        close_hands(s, {hold.ee: HOLD_GRASP["close"]}, ramp_steps=HOLD_CLOSE_STEPS)
        unscrew(s, task, twist_arm, f"{TWISTER}_hand", max_strokes=MAX_STROKES, offset=RIM_OFFSET, synergy=RIM_CLOSE,
                ramp_steps=RAMP_STEPS, preshape=RIM_OPEN, follow=RIM_FOLLOW, measured_axis=True,
                rise_back=RISE_BACK, release_steps=RELEASE_STEPS, still_release=True, back_margin=BACK_MARGIN,
                soft_end=True, stop_on_release=True, hold_gain=HOLD_GAIN, release_pose=RIM_OPEN)
        s.hold_until_success()
        return s.info
