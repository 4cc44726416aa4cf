"""Scripted solver of UnscrewCapHand (tasks/articulated/unscrew_cap/unscrew_cap_hand.py): the LEAP hand unscrews
the clamped bottle's cap in power-grasp twist strokes.

1. Rise from the rest pose and go above the cap, winding the wrist up to the start of joint 7's range
   (`phases.wind_up_above_lid`).
2. Twist strokes (`solvers.twist.unscrew`): close the power grasp on the cap, turn the wrist counter-clockwise,
   let go, turn the open hand back, grip again, until the cap is off its thread.
3. Hold until success.
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import is_wound_up, unscrew
from maniladder_ms.tasks.articulated.unscrew_cap.unscrew_cap_hand import UnscrewCapHandEnv

from .phases import FOLLOW, WIND_UP_STEPS, wind_up_above_lid

# the power grasp closes on the cap with the TCP on its axis this far (TCP frame, z down) from the cap's
# mid-height: 1 cm lower, so the curled fingertips reach under the cap's rim onto the neck
GRIP_OFFSET = (0.0, 0.0, -0.01)
RAMP_STEPS = 20  # control steps the power grasp closes over (half the default: the clamped cap cannot be pushed away)
WOUND_UP_POS_TOL = 0.01  # m: above the cap when the grip point is this near its target


@register_solver("UnscrewCapHand", control_modes=TCP_DELTA_MODES)
def solve_unscrew_cap_hand(env, seed: int) -> dict:
    """Go above the cap winding the wrist up, then power-grasp twist strokes until the cap is off."""
    with DrivenSolver.episode(env, seed) as s:
        task: UnscrewCapHandEnv = env.unwrapped
        for _ in range(WIND_UP_STEPS):
            errs = s.step({"arm": wind_up_above_lid(s, task, "arm", GRIP_OFFSET)})
            ep, _ = errs["arm"]
            if bool((ep < WOUND_UP_POS_TOL).all()) and is_wound_up(s, "arm"):
                break
        unscrew(s, task, "arm", "hand", offset=GRIP_OFFSET, synergy="power", ramp_steps=RAMP_STEPS,
                preshape="preshape", follow=FOLLOW)
        s.hold_until_success()
        return s.info
