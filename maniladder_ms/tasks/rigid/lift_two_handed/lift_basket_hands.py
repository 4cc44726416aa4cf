"""LiftBasketHands (L1 rigid DX, family LiftTwoHanded): lift a basket by its two side handles with both LEAP hands."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.basket import BasketShape, build_basket

from .base import SIDE_SIGNS, LiftTwoHandedTask


@register_task("LiftBasketHands")
class LiftBasketHandsEnv(LiftTwoHandedTask):
    """**Task:** lift a basket off the table by its two side handles, one LEAP hand on each, keeping it level.

    **Randomisation:** the basket (inner 16 x 22 cm at the floor, 16 x 22 -> 18 x 24 cm tapered, 10 cm
    deep, `basket_mass`; bar handles on the +-y sides) stands with its centre uniform in x in `basket_x_range`,
    y in `basket_y_range` and its yaw uniform in +-`basket_max_yaw`.

    **Success:** (the LiftTwoHanded family rule, `LiftTwoHandedTask`) the basket's bottom is at least
    `lift_height` above the table, it is tilted by less than `max_tilt`, and each hand holds it (`ee.holds`
    for the left and the right: a finger against the thumb or palm, or the index/middle pinch).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.25, 0.05, -0.3, 0.3)
    PARAMS = LiftTwoHandedTask.PARAMS + ("basket_mass", "basket_x_range", "basket_y_range", "basket_max_yaw")
    basket_shape = BasketShape()
    # layout ranges as (low, span)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.basket = build_basket(self.scene, "basket", self.basket_shape, self.basket_mass,
                                   color=(0.75, 0.5, 0.25, 1))
        self.item = self.basket

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.basket_x_range), uniform(b, self.basket_y_range), torch.zeros(b)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(self.basket_max_yaw)
            self.basket.set_pose(Pose.create_from_pq(xyz, yaw_quat(yaw)))

    def handle_centres(self) -> dict[str, torch.Tensor]:
        """World centres of the left (+y) and right (-y) handle bars, (num_envs, 3) each."""
        return {side: (self.basket.pose * Pose.create_from_pq(
            torch.as_tensor(self.basket_shape.handle_centre(sign), dtype=torch.float32, device=self.device)[None])).p
            for side, sign in SIDE_SIGNS.items()}

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            handles = self.handle_centres()
            obs.update(basket_pose=self.basket.pose.raw_pose,
                       left_tcp_to_handle=handles["left"] - self.ee.tcp("left").p,
                       right_tcp_to_handle=handles["right"] - self.ee.tcp("right").p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = self.reach_and_hold_reward(self.handle_centres(), info)
        both = (info["left_grasped"] & info["right_grasped"]).float()
        height = (self.basket.pose.p[:, 2] / self.lift_height).clamp(max=1)
        reward += 2 * both * height * info["is_level"]
        reward[info["success"]] = self.max_dense_reward
        return reward
