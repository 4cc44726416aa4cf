"""PourWaterHoldBowl (L1 deformable DG): one arm steadies a bowl, the other pours a cup of liquid into it."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.envs import ManiLadderEnv, register_task

from .base import CupToBowl


@register_task("PourWaterHoldBowl")
class PourWaterHoldBowlEnv(CupToBowl, ManiLadderEnv):
    """**Task:** the left arm steadies a light bowl by its rim while the right arm picks up a cup of water
    and pours it into the bowl.

    **Randomisation:**
    - the bowl (inner radius 8 cm at the rim, 5 cm tall, ~0.1 kg) stands at x in `bowl_x_range`,
      y in `bowl_y_range`;
    - the cup (plastic, inner radius 2.5 cm, 8 cm tall, 5.8 cm wide outside) stands to the right behind
      it, x in `cup_x_range`, y in `cup_y_range`, holding 80 liquid particles (low-friction spheres,
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
    PARAMS = ("success_fraction", "particle_count", "bowl_x_range", "bowl_y_range", "cup_x_range", "cup_y_range")
    held_containers = {"bowl": "left", "cup": "right"}
    bowl_density = CupToBowl.cup_density  # ~0.1 kg: light, worth holding
    bowl_color = (0.85, 0.75, 0.55, 1)
    placement_roles = ("bowl", "cup")  # the bowl's place drawn first

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
