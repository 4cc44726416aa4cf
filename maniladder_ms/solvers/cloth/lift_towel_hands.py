"""Scripted solver of LiftTowelHands (tasks/cloth/lift_towel_hands.py): each LEAP hand pinches the towel corner on
its side and both lift it until it hangs free.

1. Pinch: each hand scissor-pinches the corner on its side (`solvers.towel.pinch_side_corners`, as DragTowelHand's
   corner pinch), both close together.
2. Lift: both rise together to `HOLD_HEIGHT`, `LIFT_STEP` a step.
"""

from __future__ import annotations

import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.towel import pinch_side_corners
from maniladder_ms.tasks.cloth.lift_towel_hands import LiftTowelHandsEnv

HOLD_HEIGHT = 0.28  # the pinched corners end this high: the 17.5 cm towel hanging below them clears the table
LIFT_STEP = 0.006  # metres a control step


@register_solver("LiftTowelHands", control_modes=TCP_DELTA_MODES)
def solve_lift_towel_hands(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftTowelHandsEnv = env.unwrapped
        grasps = pinch_side_corners(s, task.towel, task.hand_corners).values()
        up = torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=task.device)
        glide(s, {g.arm: (g.p, g.p * torch.tensor([1.0, 1.0, 0.0], device=task.device) + up, g.q) for g in grasps},
              step_length=LIFT_STEP)
        s.hold_until_success()
        return s.info
