"""Scripted solver of PourWaterHoldBowl (tasks/particles/pour_particles/pour_water_hold_bowl.py): the left gripper
pinches the bowl's rim while the right takes the cup in a level side grasp and rolls it over the bowl.

1. both arms line up together: the left above the bowl's left rim, the right turned level high above its line-up
   point beside the cup (turning low, it swept the cup over);
2. both move in and close together: the left pinches the rim top-down, the right grasps the cup from its outer
   (-y) side pointing in, 30 degrees forward of y;
3. the right lifts the cup and carries it to POUR_BACK behind the bowl's centre;
4. it rolls the cup's mouth forward over the bowl and holds until the water is in.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import axis_angle_to_quaternion, quaternion_multiply

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.bimanual import Grasp, grasp_together, reach
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.particles.pour_particles.pour_water_hold_bowl import PourWaterHoldBowlEnv

GRASP_HEIGHT = 0.06  # the right TCP's height above the cup's bottom: the level hand reaches ~6 cm below it
POUR_HEIGHT = 0.13
POUR_BACK = 0.04  # the right TCP stops this far behind the bowl's centre
POUR_ROLL = 3.0  # rad (172 degrees): liquid left in the cup at 2.5
POUR_ROLL_STEPS = 40


@register_solver("PourWaterHoldBowl", control_modes=TCP_DELTA_MODES)
def solve_pour_water_hold_bowl(env, seed: int) -> dict:
    """Left: top-down pinch across the bowl's left wall. Right: level grasp of the cup from its outer (-y)
    side pointing in, 30 degrees forward of y; lift, carry behind the bowl, roll the cup's mouth forward."""
    with DrivenSolver.episode(env, seed) as s:
        task: PourWaterHoldBowlEnv = env.unwrapped
        n, device = task.num_envs, task.device
        hold = Grasp("left_arm", "left_gripper", task.rim_point(), top_down_quat(0.0, n, device),
                     torch.tensor([0.0, 0.0, 0.1], device=device))
        yaw = np.pi / 3
        pointing = torch.tensor([[np.cos(yaw), np.sin(yaw), 0.0]], device=device, dtype=torch.float32).expand(n, 3)
        # fingers closing along the horizontal; this of the two hand turns about `pointing` leaves the last
        # joint room for the roll
        closing = torch.tensor([[np.sin(yaw), -np.cos(yaw), 0.0]], device=device, dtype=torch.float32).expand(n, 3)
        q = tcp_quat(pointing, closing)
        cup_p = task.cup.pose.p + torch.tensor([0.0, 0.0, GRASP_HEIGHT], device=device)
        lined_up = cup_p - 0.1 * pointing
        # the right hand turns level high above its line-up point (turning low, it swept the cup over)
        s.move({"left_arm": (s.above(hold.p, 0.1), hold.q), "right_arm": (s.above(lined_up, 0.1), q)}, max_steps=60)
        reach(s, [hold, Grasp("right_arm", "right_gripper", cup_p, q, -0.1 * pointing)], line_up_steps=30)
        grasp_together(s, ["left_gripper", "right_gripper"])
        s.move({"right_arm": (s.above(cup_p, 0.1), q)}, max_steps=30)
        pour_p = task.bowl.pose.p + torch.tensor([-POUR_BACK, 0.0, POUR_HEIGHT], device=device)
        s.move({"right_arm": (pour_p, q)}, max_steps=40, pos_tol=0.01, rot_tol=0.05)
        # a positive turn about the pointing axis swings the cup's mouth towards pointing x up
        sign = float(np.sign(np.cross([np.cos(yaw), np.sin(yaw), 0.0], [0.0, 0.0, 1.0])[0]))
        for k in range(1, POUR_ROLL_STEPS + 1):
            turn = axis_angle_to_quaternion(pointing * sign * POUR_ROLL * k / POUR_ROLL_STEPS)
            s.step({"right_arm": (pour_p, quaternion_multiply(turn, q))})
        s.hold_until_success(max_steps=60)
        return s.info
