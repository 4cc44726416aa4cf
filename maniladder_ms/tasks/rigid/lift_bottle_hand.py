"""LiftBottleHand (L1 rigid SX): power-grasp a standing bottle with the LEAP hand and lift it."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import contact_forces
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects import containers


@register_task("LiftBottleHand")
class LiftBottleHandEnv(ManiLadderEnv):
    """**Task:** power-grasp a standing bottle with the LEAP hand and lift it off the table.

    **Randomisation:** the bottle (6 cm body diameter, 14.5 cm tall: 10 cm body, 2 cm shoulder, 2.5 cm
    neck; `bottle_mass`) stands upright, its centre uniform in x in `bottle_x_range`, y in `bottle_y_range`, its
    yaw uniform in `bottle_yaw_range` (visible only in its lighting; the bottle is round).

    **Success:** the bottle's base is >= `lift_height` above its start height (the table top), the hand
    holds it (`ee.holds`: a finger pressing against the thumb or palm, or the index / middle scissor
    pinch), and it does not touch the table: held by the hand alone.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.25, -0.05, -0.15, 0.15)
    PARAMS = ("lift_height", "bottle_mass", "bottle_x_range", "bottle_y_range", "bottle_yaw_range")
    bottle_shape = containers.bottle()
    # where the power grasp closes, above the bottle's base: on the body 3.5 cm below the shoulder (as the
    # 12 cm can is held 3.5 cm below its top), which leaves the neck under the palm
    grasp_height = bottle_shape.inner[1][0] - 0.035

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.bottle = containers.build_bottle(self.scene, "bottle", self.bottle_shape, self.bottle_mass,
                                              color=(0.2, 0.55, 0.3, 1))

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.bottle_x_range), uniform(b, self.bottle_y_range), torch.zeros(b)], dim=1)
            self.bottle.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.bottle_yaw_range))))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(bottle_pose=self.bottle.pose.raw_pose, tcp_to_bottle_pos=self.bottle.pose.p - self.ee.tcp().p)
        return obs

    def evaluate(self):
        height = self.bottle.pose.p[:, 2]  # of the base above the table, where it starts
        is_grasped = self.ee.holds(self.bottle)
        on_table = contact_forces(self.scene, self.ladder_scene.table, [self.bottle])[0].norm(dim=1) > 1e-3
        is_lifted = height >= self.lift_height
        return {
            "success": is_lifted & is_grasped & ~on_table,
            "is_lifted": is_lifted,
            "is_grasped": is_grasped,
            "on_table": on_table,
            "height": height,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach the grasp point on the body, grasp, then lift
        grasp_point = self.bottle.pose.p + torch.tensor([0, 0, self.grasp_height], device=self.device)
        reach = 1 - torch.tanh(5 * torch.linalg.norm(grasp_point - self.ee.tcp().p, dim=1))
        is_grasped = info["is_grasped"].float()
        lift = (info["height"] / self.lift_height).clamp(0, 1)
        reward = reach + is_grasped + 2 * lift * is_grasped
        reward[info["success"]] = self.max_dense_reward
        return reward
