"""Scripted solver of OpenJarBimanual (tasks/articulated/unscrew_cap/open_jar_bimanual.py): the left gripper holds
the jar's body from the side while the right gripper twists the lid off in top-down strokes.

1. The left gripper lines up beside the jar while the right rises above the lid winding its wrist up
   (`phases.wind_up_above_lid`).
2. The left settles on its line-up point, moves in and closes across the jar's body.
3. Twist strokes with the right gripper (`solvers.twist.unscrew`): grip the lid, turn the wrist counter-clockwise,
   let go, turn back, grip again, until the lid is off its thread.
4. Hold until success.
"""

from __future__ import annotations

import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.bimanual import Grasp
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import is_wound_up, unscrew
from maniladder_ms.tasks.articulated.unscrew_cap.open_jar_bimanual import OpenJarBimanualEnv

from .phases import wind_up_above_lid

# the left gripper holds the jar's body from the +y side (pointing along world -y, fingers closing along
# world x), its TCP this high: clear of the table below (the sideways hand reaches ~6 cm below its TCP)
# and of the right gripper's fingers on the lid above
HOLD_HEIGHT = 0.065
LEFT_APPROACH = 0.15  # m out from the jar where the left lines up (nearer, its turning hand knocked the jar)
LINE_UP_STEPS = 70  # at most this many control steps for the line-up and the wind-up
LINED_UP_POS_TOL, LINED_UP_ROT_TOL = 0.01, 0.05  # m, rad: the left is lined up
SETTLE_STEPS, SETTLE_POS_TOL, SETTLE_ROT_TOL = 40, 0.005, 0.03  # the left's line-up made exact before it moves in
MOVE_IN_STEPS, MOVE_IN_POS_TOL = 40, 0.003


@register_solver("OpenJarBimanual", control_modes=TCP_DELTA_MODES)
def solve_open_jar_bimanual(env, seed: int) -> dict:
    """Left: sideways grasp across the jar's body; right: top-down grip on the lid and twist strokes until the
    lid is off."""
    with DrivenSolver.episode(env, seed) as s:
        task: OpenJarBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        centre = task.jar.pose.p
        hold_p = centre + torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=device)
        pointing = torch.tensor([[0.0, -1.0, 0.0]], device=device).expand(n, 3)
        closing = torch.tensor([[1.0, 0.0, 0.0]], device=device).expand(n, 3)
        hold = Grasp("left_arm", "left_gripper", hold_p, tcp_quat(pointing, closing), -LEFT_APPROACH * pointing)
        for _ in range(LINE_UP_STEPS):
            errs = s.step({"left_arm": hold.lined_up, "right_arm": wind_up_above_lid(s, task, "right_arm")})
            ep, er = errs["left_arm"]
            if bool((ep < LINED_UP_POS_TOL).all() and (er < LINED_UP_ROT_TOL).all()) and is_wound_up(s, "right_arm"):
                break
        s.move({"left_arm": hold.lined_up}, max_steps=SETTLE_STEPS, pos_tol=SETTLE_POS_TOL, rot_tol=SETTLE_ROT_TOL)
        s.move({"left_arm": (hold.p, hold.q)}, max_steps=MOVE_IN_STEPS, pos_tol=MOVE_IN_POS_TOL)
        s.grasp("left_gripper")
        unscrew(s, task, "right_arm", "right_gripper")
        s.hold_until_success()
        return s.info
