"""Scripted solver of CableIntoClipHand (tasks/rope/cable_into_clip_hand.py): the LEAP hand scissor-pinches the
cable's middle capsule, carries it over the clip's slot turned onto the slot's axis, lets it go just above the
walls, then presses it home with the closed fingers (the phases: `solvers/rope/clip_phases.py`, shared with
RouteCableClipsHand).

1. `lay_over_clip`: scissor-pinch the middle capsule (fingers along the cable) and lift it `CARRY_LIFT` over the
   walls' top.
2. `lay_over_clip`: carry it over the slot's centre, turning it onto the slot's axis.
3. `servo_capsule`: servo the pinched capsule (not the hand) onto the slot's centre, then lower it, still
   servoing, to `RELEASE_ABOVE_TOP`; open the fingers.
4. `press_home`: rise `PRESS_RISE`, close the fingers, press down `PRESS_DEPTH` into the cable; tap again over each
   neighbour (`PRESS_TAPS`), withdraw upwards.
5. Hold still until success.
"""

from __future__ import annotations

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.rope.clip_phases import lay_over_clip, press_home


@register_solver("CableIntoClipHand", control_modes=TCP_DELTA_MODES)
def solve_cable_into_clip_hand(env, seed: int) -> dict:
    """`lay_over_clip`, then `press_home`, then hold still until the task reports success."""
    with DrivenSolver.episode(env, seed) as s:
        task = env.unwrapped
        low, q = lay_over_clip(s, task, task.clip, task.grasp_segment)
        press_home(s, task, task.clip, low, q)
        s.hold_until_success()
        return s.info
