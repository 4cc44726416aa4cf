"""Scripted solver of MoldClayHand (tasks/clay/mold_clay_hand.py): press the lump into the mould with the open hand's
palm, twice: halfway down first, then flat onto the rim.

1. Open the hand with the thumb raised (`open_thumb_up`) and bring the palm level over the mould, its sides along the
   mould's walls, `PALM_HOVER` above the table.
2. First press: lower the palm to `HALF_PRESS_Z` over `PALM_DESCENT_STEPS`, hold `PALM_HOLD_STEPS`, lift to
   `PALM_HOVER`: the 3-layer lump is squashed to about two layers, spreading out from its own middle.
3. Second press: the same down to `PALM_PRESS_Z` (below the table: the arm presses hard and the rim stops the palm),
   then lift: the clay is pressed into a single layer under the rim, out into the mould's columns.
4. Hold still until success.

In both presses the palm is aimed tilted by `PRESS_PITCH` (the arm gives way under the press and tilts the hand
towards the robot) and its top-down aim is corrected every step by `AIM_GAIN` of its error.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import (axis_angle_to_quaternion, quaternion_apply,
                                                              quaternion_multiply)

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.tasks.clay.mold_clay_hand import MoldClayHandEnv

# the open hand's palm (its collision box's bottom face, thumb raised) in the frame of a top-down TCP: its centre
# 2.95 cm behind and 3.7 cm to the right of the TCP, 8.1 cm above it (measured on the hand's collision boxes)
PALM_IN_TCP = (-0.0295, 0.037, -0.081)
OPEN_STEPS = 10  # control steps the hand takes to open flat
PALM_HOVER = 0.06  # palm height above the table before and between the presses (clears the 3.6 cm lump)
# palm height the first press aims at: about two particle layers (seeds 100-109: 10/10 filled after both presses
# against 9/10 after a single full press, the row of the mould farthest from the lump's middle left empty)
HALF_PRESS_Z = 0.022
PALM_PRESS_Z = -0.02  # the second press aims the palm this far below the table: the rim stops it
PALM_DESCENT_STEPS = 25
PALM_HOLD_STEPS = 15
# rad about world y: the palm aimed tilted with its side towards the robot raised. Pressing level, the arm gave way
# and the palm stood 1.3 cm lower on that side than on the far one (the clay squeezed away from the robot, its
# near row empty); single presses on seeds 100-109 filled 9, 9, 9 and 7 of 10 moulds at 0.03, 0.06, 0.1, 0.14 rad
PRESS_PITCH = 0.06
AIM_GAIN = 0.5  # share of the palm's top-down error added to its aim each step of a press (the arm slides sideways)


def press(s: DrivenSolver, task: MoldClayHandEnv, palm_z: float):
    """Phases 2-3: the open hand's palm lowered onto the mould towards height `palm_z`, held, lifted."""
    n, device = task.num_envs, task.device
    q = top_down_quat(DrivenSolver.neutral_yaw(task.mould.yaw(), np.pi / 2), n, device)
    palm_local = torch.tensor(PALM_IN_TCP, device=device).expand(n, 3)
    palm = quaternion_apply(q, palm_local)
    centre = task.mould.pose.p.clone()
    tilt = torch.tensor([0.0, PRESS_PITCH, 0.0], device=device).expand(n, 3)
    q_press = quaternion_multiply(axis_angle_to_quaternion(tilt), q)
    aim = torch.zeros(n, 3, device=device)
    flat = torch.tensor([1.0, 1.0, 0.0], device=device)
    s.move({"arm": (s.above(centre, PALM_HOVER) - palm, q)}, max_steps=60, pos_tol=0.01)
    heights = list(np.linspace(PALM_HOVER, palm_z, PALM_DESCENT_STEPS)) + [palm_z] * PALM_HOLD_STEPS
    for z in heights:
        s.step({"arm": (s.above(centre + aim, float(z)) - palm, q_press)})
        tcp = s.tcp()
        aim += AIM_GAIN * (centre - tcp.p - quaternion_apply(tcp.q, palm_local)) * flat
    s.move({"arm": (s.above(centre, PALM_HOVER) - palm, q)}, max_steps=20, pos_tol=0.01)


@register_solver("MoldClayHand", control_modes=TCP_DELTA_MODES)
def solve_mold_clay_hand(env, seed: int) -> dict:
    """Open the hand flat; press the lump halfway down with the palm, then flat onto the mould's rim."""
    with DrivenSolver.episode(env, seed) as s:
        task: MoldClayHandEnv = env.unwrapped
        s.set_ee("hand", LEAP_SYNERGIES["open_thumb_up"], steps=OPEN_STEPS)
        press(s, task, HALF_PRESS_Z)
        press(s, task, PALM_PRESS_Z)
        s.hold_until_success()
        return s.info
