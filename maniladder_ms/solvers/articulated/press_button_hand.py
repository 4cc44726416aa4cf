"""Scripted solver of PressButtonHand (tasks/articulated/press_button_hand.py): the pointing index finger comes
down on the cap's centre and presses the cap to its stop.

1. Point the index finger (the "point" hand posture) and bring the TCP `APPROACH_HEIGHT` above the cap, top-down.
2. Shift the hand so the fingertip (not the TCP) is above the cap's centre.
3. Press: the fingertip's target `PRESS_PAST_STOP` below the cap's bottom stop.
4. Hold until success.
"""

from __future__ import annotations

import torch

from maniladder_ms.agents.effectors import leap_fingertip

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.articulated.press_button_hand import PressButtonHandEnv

HAND_YAW = 0.0  # rad, the top-down hand's yaw (the round cap needs no particular one)
POINT_STEPS = 1  # control steps the hand takes to point
ABOVE_STEPS, TIP_ABOVE_STEPS, PRESS_STEPS = 40, 30, 15  # at most this many control steps for each move
# m the fingertip's target lies below the cap's bottom stop: the arm yields a few mm to the spring before the cap
# gets there
PRESS_PAST_STOP = 0.004


@register_solver("PressButtonHand", control_modes=TCP_DELTA_MODES)
def solve_press_button_hand(env, seed: int) -> dict:
    """Point the index finger down, bring its tip above the cap's centre, press the cap down to its stop."""
    with DrivenSolver.episode(env, seed) as s:
        task: PressButtonHandEnv = env.unwrapped
        q = top_down_quat(HAND_YAW, task.num_envs, device=task.device)
        s.set_ee("hand", "point", steps=POINT_STEPS)
        above = task.cap_top() + torch.tensor([0, 0, APPROACH_HEIGHT], device=task.device)
        s.move({"arm": (above, q)}, max_steps=ABOVE_STEPS)
        # the fingertip's offset from the TCP, the finger pointing (world frame; the hand keeps its orientation)
        tip_offset = leap_fingertip(task.agent) - task.ee.tcp().p
        s.move({"arm": (above - tip_offset, q)}, max_steps=TIP_ABOVE_STEPS)
        pressed = task.cap_top() - torch.tensor([0, 0, task.button_shape.travel + PRESS_PAST_STOP], device=task.device)
        s.move({"arm": (pressed - tip_offset, q)}, max_steps=PRESS_STEPS)
        s.hold_until_success()
        return s.info
