"""LiftRopeHand (L1 deformable SX): pick a rope off the table with the LEAP hand."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.tasks.rope.base import RopeTask


@register_task("LiftRopeHand")
class LiftRopeHandEnv(RopeTask, ManiLadderEnv):
    """**Task:** a rope lies on the table; pick it up with the LEAP hand, so that at least half of it
    hangs well clear of the table.

    **Randomisation:** the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter) lies flat in
    a gentle S: the in-plane turn between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 20 + phase), amp
    uniform in [0, `rope_max_amp`], phase uniform; the mean of its capsule centres is at x uniform in
    `rope_x_range`, y uniform in `rope_y_range`; its first capsule's heading is uniform in `rope_yaw_range`.

    **Success:** at least `min_lifted` of the rope's segments (capsule centres) are at least
    `lift_height` above the table, and the hand holds the rope (`ee.holds` on any of its capsules: a
    finger against the thumb or palm, or the index / middle scissor pinch).

    `is_grasped` (reward and observation only): the hand holds one of the five capsules around the middle
    (`ee.holds`; the solver's "scissor" pinch).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 4
    TASK_REGION = (-0.35, 0.15, -0.3, 0.3)
    PARAMS = ("lift_height", "min_lifted", "rope_x_range", "rope_y_range", "rope_yaw_range", "rope_max_amp")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            self.lay_wavy(b)

    def _segments(self) -> torch.Tensor:
        """Capsule centres, [B, segments, 3]."""
        return self.rope.points()[:, 1:-1]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1),
                       tcp_to_grasp_segment=self.rope.links[self.grasp_segment].pose.p - self.ee.tcp().p)
        return obs

    def evaluate(self):
        lifted_fraction = (self._segments()[..., 2] >= self.lift_height).float().mean(dim=1)
        middle = self.grasp_segment
        is_grasped = self.ee.holds(self.rope.links[middle - 2:middle + 3])
        is_held = self.ee.holds(self.rope.links)
        return {
            "success": (lifted_fraction >= self.min_lifted) & is_held,
            "lifted_fraction": lifted_fraction,
            "is_held": is_held,
            "is_grasped": is_grasped,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        target = self.rope.links[self.grasp_segment].pose.p
        reach = 1 - torch.tanh(5 * torch.linalg.norm(target - self.ee.tcp().p, dim=1))
        lift = (info["lifted_fraction"] / self.min_lifted).clamp(0, 1)
        reward = reach + info["is_grasped"].float() + 2 * lift
        reward[info["success"]] = self.max_dense_reward
        return reward
