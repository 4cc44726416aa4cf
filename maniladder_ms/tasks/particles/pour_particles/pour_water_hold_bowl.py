"""PourWaterHoldBowl (L1 deformable DG): one arm steadies a bowl, the other pours a cup of liquid into it."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import axis_angle_to_quaternion, quaternion_multiply

from maniladder_ms.agents.helpers import top_down_quat
from .base import CupToBowl
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, grasp_together, reach, tcp_quat
from maniladder_ms.solvers.driven import DrivenSolver


@register_task("PourWaterHoldBowl")
class PourWaterHoldBowlEnv(CupToBowl, ManiLadderEnv):
    """**Task:** the left arm steadies a light bowl by its rim while the right arm picks up a cup of water
    and pours it into the bowl.

    **Randomisation:**
    - the bowl (inner radius 8 cm at the rim, 5 cm tall, ~0.1 kg) stands at x in [0, 0.06],
      y in [-0.04, 0.04];
    - the cup (plastic, inner radius 2.5 cm, 8 cm tall, 5.8 cm wide outside) stands to the right behind
      it, x in [-0.16, -0.1], y in [-0.26, -0.18], holding 80 liquid particles (low-friction spheres,
      radius 4 mm) packed from its floor with a small random jitter.

    **Success:** (`CupToBowl.held_pour_metrics`, the PourParticles rule) at least `success_fraction` of the
    `particle_count` liquid particles lie inside the bowl's inner volume (below its rim, `particles.fraction_inside`);
    the left gripper holds the bowl (`ee.holds`) and the right gripper the cup, now and on every step
    since the first particle landed in the bowl (episode memory `bowl_let_go`, `cup_let_go`): the bowl
    is held while the water goes in, and the water is poured from the held cup, not knocked over.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.15, -0.32, 0.15)
    PARAMS = ("success_fraction", "particle_count")
    held_containers = {"bowl": "left", "cup": "right"}
    bowl_density = CupToBowl.cup_density  # ~0.1 kg: light, worth holding
    bowl_color = (0.85, 0.75, 0.55, 1)
    placement = {"bowl": ((0.0, 0.06), (-0.04, 0.04)), "cup": ((-0.16, -0.1), (-0.26, -0.18))}

    def rim_point(self) -> torch.Tensor:
        """The middle of the bowl's wall at its left (+y) rim, 1 cm below the rim: where the left arm holds it."""
        r = self.bowl_shape.rim_radius + self.bowl_shape.wall / 2
        return self.bowl.pose.p + torch.tensor([0.0, r, self.bowl_shape.height - 0.01], device=self.device)

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   bowl_held=info["bowl_held"], cup_grasped=info["cup_grasped"])
        if "state" in self.obs_mode:
            obs.update(self._cup_and_bowl_obs())
        return obs

    def evaluate(self):
        metrics = self.held_pour_metrics()  # bowl_held, cup_held, bowl_let_go, cup_let_go
        return {**metrics, "cup_grasped": metrics["cup_held"], "cup_lifted": self.cup.pose.p[:, 2] > 0.05}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # left: reach and hold the rim; right: reach the cup's side, grasp, lift, carry behind the bowl;
        # then the water in the bowl
        reach_rim = 1 - torch.tanh(5 * torch.linalg.norm(self.rim_point() - self.ee.tcp("left").p, dim=1))
        cup_mid = self.cup.pose.p + torch.tensor([0, 0, self.cup_shape.height / 2], device=self.device)
        reach_cup = 1 - torch.tanh(5 * torch.linalg.norm(cup_mid - self.ee.tcp("right").p, dim=1))
        grasped = info["cup_grasped"].float()
        carry = 1 - torch.tanh(5 * torch.linalg.norm((self.bowl.pose.p - self.cup.pose.p)[:, :2], dim=1))
        reward = 0.5 * (reach_rim + info["bowl_held"].float()) + 0.5 * reach_cup + grasped
        reward += carry * grasped * info["cup_lifted"]
        reward += 2 * self.pour_reward(info)
        reward[info["success"]] = self.max_dense_reward
        return reward


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
