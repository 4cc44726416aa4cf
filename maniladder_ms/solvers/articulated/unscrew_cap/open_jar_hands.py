"""Scripted solver of OpenJarHands (tasks/articulated/unscrew_cap/open_jar_hands.py): the left LEAP hand holds the
free jar in a side grasp with its palm on the body while the right LEAP hand unscrews the lid in rim-pinch twist
strokes.

1. From the ready pose the holding hand preshapes and comes down to its line-up point beside the jar while the
   twisting hand rises above the lid winding its wrist up (`phases.wind_up_above_lid`).
2. The holding hand moves in and closes round the jar's body.
3. Twist strokes with the twisting hand (`solvers.twist.unscrew`): pinch the lid's rim from above, turn the wrist
   counter-clockwise about the lid's measured axis with the TCP held in place (an integral term), open to the rim
   preshape with the arm still, rise, turn back, pinch again, until the lid is off its thread.
4. Hold until success.
"""

from __future__ import annotations

import numpy as np

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import close_hands
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import is_wound_up, unscrew
from maniladder_ms.tasks.articulated.unscrew_cap.open_jar_hands import HOLDER, TWISTER
from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.solvers.side_grasps import LINE_UP_ABOVE, SIDE_PRESHAPE_STEPS, lined_up_side_grasp

from .phases import FOLLOW, WIND_UP_STEPS, wind_up_above_lid

# The holding hand's side grasp on the jar's body (`solvers.bimanual.side_grasp`, PourGrainsHandToCup's pourer
# grasp and ready pose): palm normal along -y, level, thumb low, the TCP 4.5 cm past the jar's axis so the palm
# meets the body (palm off the jar, the jar tipped 15-40 deg in the fingertip grip while the other hand closed and
# twisted; with the palm on it, 4-7 deg). The grasp centre 8 cm up the 16 cm body (seeds 100-149: 43/50 there,
# 37/50 at 9.5 cm); the ring finger stays open (curled, it reached the lid)
HOLD_GRASP = dict(yaw=-np.pi / 2, pitch=0.0, up=-1.0, height=0.08, shift=0.04, inwards=0.045,
                  approach="preshape", close=LEAP_SYNERGIES["side_power_ring_open"])
READY_POS_TOL = 0.01  # m: both arms are at their targets
MOVE_IN_STEPS, MOVE_IN_POS_TOL = 40, 0.003
HOLD_CLOSE_STEPS = 20  # control steps the holding hand closes over

RIM_OPEN = LEAP_SYNERGIES["rim_open"]
RIM_CLOSE = LEAP_SYNERGIES["rim_close"]
RIM_OFFSET = (-0.0205, 0.007, 0.0395)  # the lid's mid-height centre in the TCP frame where the rim grasp closes
RAMP_STEPS = 40  # control steps the rim grasp closes over (the held jar gives)
# the arm's IK-step controller left the TCP 1.0 cm high and 0.9 cm off under the hand's load: an integral on the
# TCP position (`twist.HoldPosition`) with this gain while reaching, closing and turning puts the lid within 1 mm
# of the planned point
HOLD_GAIN = 0.3
RISE_BACK = 0.08  # m above the lid top where the opened hand turns back between strokes
RELEASE_STEPS = 15  # control steps the hand opens over between strokes, the arm held still
# the open hand turns back this much (rad) past the rest of the turn: a regrasp on a lid off its home stop turned
# it back 0.8-0.9 rad as the hand closed
BACK_MARGIN = 1.2
# FOLLOW (`phases`) is the power grasp's: the rim grasp turns the lid ~1:1, so the turn back between strokes is
# ~1 rad longer than it needs to be (the two-stroke episodes take 501-657 steps)


def hold_and_twist(env, seed: int, rim_offset, **strokes) -> dict:
    """The two-hand UnscrewCap solvers' phases: left, side grasp on the vessel's body from the ready pose; right,
    rise, wind the wrist up above the lid, then rim-grasp twist strokes (`twist.unscrew`, with `strokes`: follow,
    back_margin, max_strokes) until the lid is off."""
    with DrivenSolver.episode(env, seed) as s:
        task = env.unwrapped
        hold, _ = lined_up_side_grasp(f"{HOLDER}_arm", f"{HOLDER}_hand", task.jar.pose.p, HOLD_GRASP)
        twist_arm = f"{TWISTER}_arm"
        s.set_ee(hold.ee, HOLD_GRASP["approach"], steps=0)
        for k in range(WIND_UP_STEPS):
            target = (s.above(hold.lined_up[0], LINE_UP_ABOVE), hold.q) if k < SIDE_PRESHAPE_STEPS else hold.lined_up
            errs = s.step({hold.arm: target, twist_arm: wind_up_above_lid(s, task, twist_arm, rim_offset)})
            ep, _ = errs[twist_arm]
            hp, _ = errs[hold.arm]
            if (k >= SIDE_PRESHAPE_STEPS and bool((ep < READY_POS_TOL).all() and (hp < READY_POS_TOL).all())
                    and is_wound_up(s, twist_arm)):
                break
        s.move({hold.arm: (hold.p, hold.q)}, max_steps=MOVE_IN_STEPS, pos_tol=MOVE_IN_POS_TOL)
        close_hands(s, {hold.ee: HOLD_GRASP["close"]}, ramp_steps=HOLD_CLOSE_STEPS)
        unscrew(s, task, twist_arm, f"{TWISTER}_hand", offset=rim_offset, synergy=RIM_CLOSE, ramp_steps=RAMP_STEPS,
                preshape=RIM_OPEN, measured_axis=True, rise_back=RISE_BACK, release_steps=RELEASE_STEPS,
                still_release=True, soft_end=True, stop_on_release=True, hold_gain=HOLD_GAIN, release_pose=RIM_OPEN,
                **strokes)
        s.hold_until_success()
        return s.info


@register_solver("OpenJarHands", control_modes=TCP_DELTA_MODES)
def solve_open_jar_hands(env, seed: int) -> dict:
    """Left: side grasp on the jar's body from the ready pose; right: rise, wind the wrist up above the lid,
    then rim-grasp twist strokes until the lid is off (`hold_and_twist`)."""
    return hold_and_twist(env, seed, RIM_OFFSET, follow=FOLLOW, back_margin=BACK_MARGIN)
