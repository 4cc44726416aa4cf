"""Scripted solver of PourWaterBimanual (tasks/particles/pour_particles/pour_water_bimanual.py): both grippers take
level side grasps and lift their cups; the left holds the receiver still in the middle while the right rolls the
source over it.

1. both arms line up above their line-up points, move in and close together on their cups;
2. both lift LIFT;
3. together, the left brings the receiver to RECEIVER_AT, its bottom RECEIVER_BOTTOM up, and the right carries the
   source SOURCE_BACK beside it, its bottom SOURCE_ABOVE over the receiver's rim;
4. the right rolls the source about its pointing axis, the mouth steered over the receiver's and the source's
   bottom edge clear of its rim (`pouring.steer_roll`), and holds until the water is in.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.pouring import steer_roll
from maniladder_ms.tasks.particles.pour_particles.pour_water_bimanual import PourWaterBimanualEnv

GRASP_HEIGHT = 0.05  # TCP height above each cup's bottom for the level side grasps
SOURCE_YAW = np.pi / 3  # the right gripper's pointing (as PourWaterHoldBowl's pourer)
RECEIVER_YAW = -np.pi / 2  # the left gripper points -y: it holds the receiver from its outer side
LIFT = 0.1
# where the left arm holds the receiver for the pour: its bottom at this height, its axis here (x, y)
RECEIVER_AT, RECEIVER_BOTTOM = (-0.06, 0.06), 0.1
SOURCE_BACK = 0.08  # the upright source's mouth this far from the receiver's, against the pour direction
SOURCE_ABOVE = 0.05  # the source's bottom this far above the receiver's rim while carried
MOUTH_ABOVE = 0.02  # the end of the mouth's path above the receiver's rim
POUR_ROLL, POUR_ROLL_STEPS, POUR_HOLD_STEPS = 3.0, 50, 40
CLEAR = 0.015


def _level_grasp(cup: torch.Tensor, yaw: float, closing_sign: float, height: float):
    n, device = cup.shape[0], cup.device
    pointing = torch.tensor([[np.cos(yaw), np.sin(yaw), 0.0]], device=device, dtype=torch.float32).expand(n, 3)
    closing = closing_sign * torch.tensor([[np.sin(yaw), -np.cos(yaw), 0.0]], device=device,
                                          dtype=torch.float32).expand(n, 3)
    return cup + torch.tensor([0.0, 0.0, height], device=device), tcp_quat(pointing, closing), pointing


@register_solver("PourWaterBimanual", control_modes=TCP_DELTA_MODES)
def solve_pour_water_bimanual(env, seed: int) -> dict:
    """Both grippers take level side grasps on their cups, lift them; the left brings the receiver to the
    middle, the right carries the source beside and above it and rolls it, the mouth steered over the
    receiver's."""
    with DrivenSolver.episode(env, seed) as s:
        task: PourWaterBimanualEnv = env.unwrapped
        device = task.device
        rp, rq, rpoint = _level_grasp(task.bowl.pose.p, RECEIVER_YAW, -1.0, GRASP_HEIGHT)
        sp, sq, spoint = _level_grasp(task.cup.pose.p, SOURCE_YAW, 1.0, GRASP_HEIGHT)
        grasps = [Grasp("left_arm", "left_gripper", rp, rq, -0.1 * rpoint),
                  Grasp("right_arm", "right_gripper", sp, sq, -0.1 * spoint)]
        s.move({g.arm: (s.above(g.lined_up[0], 0.1), g.q) for g in grasps}, max_steps=60)
        reach(s, grasps, line_up_steps=30)
        grasp_together(s, ["left_gripper", "right_gripper"])
        up = torch.tensor([0.0, 0.0, LIFT], device=device)
        s.move({"left_arm": (rp + up, rq), "right_arm": (sp + up, sq)}, max_steps=25, pos_tol=0.01)
        # the receiver to the middle, the source beside it, its bottom above the receiver's rim
        held_l = s.tcp("left_arm").p - task.bowl.pose.p
        goal_l = torch.tensor([[*RECEIVER_AT, RECEIVER_BOTTOM]], device=device) + held_l
        rim_z = RECEIVER_BOTTOM + task.bowl_shape.height
        # a positive turn about the pointing axis swings the mouth towards pointing x up
        pour_dir = torch.linalg.cross(spoint, torch.tensor([[0.0, 0.0, 1.0]], device=device).expand_as(spoint))
        held_r = s.tcp("right_arm").p - task.cup.pose.p
        goal_r = torch.tensor([[*RECEIVER_AT, rim_z + SOURCE_ABOVE]], device=device) - SOURCE_BACK * pour_dir + held_r
        goal_r[:, 2] = rim_z + SOURCE_ABOVE + held_r[:, 2]
        glide(s, {"left_arm": (s.tcp("left_arm").p, goal_l, rq), "right_arm": (s.tcp("right_arm").p, goal_r, sq)},
              step_length=0.012, settle_steps=15)
        mouth = task.bowl.pose.p + quaternion_apply(
            task.bowl.pose.q, torch.tensor([[0.0, 0.0, task.bowl_shape.height + MOUTH_ABOVE]], device=device))
        steer_roll(s, task, "right_arm", spoint, sq, mouth, task.bowl.pose.p[:, 2] + task.bowl_shape.height,
                   POUR_ROLL, POUR_ROLL_STEPS, POUR_HOLD_STEPS, CLEAR)
        s.hold_until_success(max_steps=30)
        return s.info
