"""LiftTowelHands (L1 deformable DX): both LEAP hands lift a towel by two corners until it hangs free."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.tasks.cloth.base import SIDES, lay_between_hands, side_corners


@register_task("LiftTowelHands")
class LiftTowelHandsEnv(ManiLadderEnv):
    """**Task:** a towel lies flat on the table between the two arms, one corner towards each arm; each
    LEAP hand takes the corner on its side and together they lift the towel until it hangs free of the table.

    **Randomisation:** the towel (`cloth.towel(8, 8)`: 2.5 cm particle spacing, particles of 1 cm radius,
    17.5 cm between corner centres, 24.7 cm across the diagonal) lies flat, its centre at x uniform in
    `towel_x_range`, y uniform in `towel_y_range`, its edges turned by a yaw uniform in `towel_yaw_range` (the
    diagonal between the two hands' corners 85-105 degrees from the x axis; `tasks/cloth/base.py`'s
    `lay_between_hands`).

    **Success:** every towel particle is at least `clearance` above the table (its lowest point, centre
    minus radius), and each hand holds the corner particle on its side (`left_grasped`, `right_grasped`:
    `ee.holds`, the "scissor" pinch the solver uses or a finger against the thumb or palm).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.28, 0.08, -0.2, 0.2)  # towel centres plus the towel's half diagonal
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("clearance", "towel_x_range", "towel_y_range", "towel_yaw_range")
    GRID = (8, 8)  # the towel's particle rows and columns

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.towel = cloth.build_cloth(self.scene, "towel", cloth.towel(*self.GRID, self.cloth_config.spacing),
                                       self.cloth_config)
        self.hand_corners = side_corners(self.towel.layout)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            lay_between_hands(self.towel, len(env_idx), x_range=self.towel_x_range, y_range=self.towel_y_range,
                              yaw_range=self.towel_yaw_range)

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        obs.update(left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            points = self.towel.positions()
            obs["towel_points"] = points.flatten(1)
            for side, i in self.hand_corners.items():
                obs[f"{side}_tcp_to_corner"] = points[:, i] - self.ee.tcp(side).p
        return obs

    def evaluate(self):
        lowest = self.towel.positions()[..., 2].amin(dim=1) - self.cloth_config.radius
        grasped = {side: self.ee.holds(self.towel.spheres[i], side) for side, i in self.hand_corners.items()}
        return {
            "success": (lowest >= self.clearance) & grasped["left"] & grasped["right"],
            "lowest": lowest,
            "left_grasped": grasped["left"],
            "right_grasped": grasped["right"],
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        points = self.towel.positions()
        reward = sum(1 - torch.tanh(5 * torch.linalg.norm(points[:, i] - self.ee.tcp(side).p, dim=1))
                     for side, i in self.hand_corners.items())
        both = info["left_grasped"] & info["right_grasped"]
        reward += info["left_grasped"].float() + info["right_grasped"].float()
        reward += 2 * both * (info["lowest"] / self.clearance).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
