"""Scripted solver of PressClayFlat (tasks/clay/flatten_clay/press_clay_flat.py): press the closed gripper's
fingertips straight down into the clay, first at the ball's centre, then wherever the clay is highest, until it
is flat and spread (a handful of strokes).

1. Close the gripper.
2. A stroke: hover over the target (`FIRST_HOVER` over the ball's centre, later `HOVER` over the highest
   particle), press down to `PRESS_Z` for `PRESS_STEPS`, correcting the aim (`AIM_GAIN`), rise to `HOVER`.
3. Repeat 2 until the clay is flat and spread with a margin (`HEIGHT_MARGIN`, `AREA_MARGIN`) or a stroke
   would start after `LAST_STROKE_START`.
4. Hold still until success.
"""

from __future__ import annotations

import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.clay.flatten_clay.phases import flat_with_margin
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.clay.flatten_clay.press_clay_flat import PressClayFlatEnv

FIRST_HOVER = 0.075  # TCP height above the ball before the first stroke: the fingertips clear a 6.8 cm ball
HOVER = 0.05  # TCP height between later strokes: the fingertips clear the pressed clay (< 3.5 cm high)
# TCP target of a stroke: the fingertips (9 mm below the TCP) aimed 1 mm above the table, so the arm pushes
# hard (it stalls on the clay about 1.5 cm higher) but never drives a particle into the table (aiming at
# the table pushed particles through it or wedged them between the fingertips)
PRESS_Z = 0.01
PRESS_STEPS = 8
# The fingertips stick in the clay while the arm gives way, and the TCP ends a stroke about 1.2 cm off
# (towards +x) from where it was sent: the aim point is corrected by this share of the error every step
AIM_GAIN = 0.5
# strokes go on until the clay is this far past both thresholds once the fingers are out of it, or until the
# last stroke that fits the horizon
HEIGHT_MARGIN, AREA_MARGIN = 0.03, 0.1
LAST_STROKE_START = 125


@register_solver("PressClayFlat", control_modes=TCP_DELTA_MODES)
def solve_press_clay_flat(env, seed: int) -> dict:
    """Close the gripper; press strokes, first at the ball's centre, then wherever the clay is highest."""
    with DrivenSolver.episode(env, seed) as s:
        task: PressClayFlatEnv = env.unwrapped
        n, device = task.num_envs, task.device
        flat = torch.tensor([1.0, 1.0, 0.0], device=device)
        q = top_down_quat(0.0, n, device)
        s.grip(True, steps=0)
        target, hover, aim = task.clay_center(), FIRST_HOVER, torch.zeros(n, 3, device=device)
        while True:
            s.move({"arm": (s.above(target + aim, hover), q)}, max_steps=40, pos_tol=0.01)
            for _ in range(PRESS_STEPS):
                s.step({"arm": (s.above(target + aim, PRESS_Z), q)})
                aim += AIM_GAIN * (target - s.tcp().p) * flat
            up = s.tcp().p.clone()
            up[:, 2] = HOVER
            s.move({"arm": (up, q)}, max_steps=10, pos_tol=0.01)
            info = s.info
            done = flat_with_margin(task, info, HEIGHT_MARGIN, AREA_MARGIN)
            if bool(done.all()) or int(info["elapsed_steps"].min()) > LAST_STROKE_START:
                break
            target, hover = task.highest_point(), HOVER
        s.hold_until_success()
        return s.info
