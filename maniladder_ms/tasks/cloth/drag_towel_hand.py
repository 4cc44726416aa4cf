"""DragTowelHand (L1 deformable SX): pinch a towel corner with the LEAP hand and drag the towel onto a target."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker

ROWS = COLS = 8


@register_task("DragTowelHand")
class DragTowelHandEnv(ManiLadderEnv):
    """**Task:** a towel lies flat on the table and a round target is marked beside it; pinch a corner of
    the towel with the LEAP hand and drag the towel over the table until its centre lies on the target.

    **Randomisation:**
    - the towel (`cloth.towel(8, 8)`: 2.5 cm particle spacing, particles of 1 cm radius, 17.5 cm between
      corner centres) lies flat, its centre at x uniform in `towel_x_range`, y uniform in `towel_y_range`, its
      edges turned by a yaw uniform in +-`towel_max_yaw`;
    - the target's centre lies a distance uniform in `target_distance_range` from the towel's centre, in a
      direction uniform in +-`target_max_bearing` from +x (never towards the robot's base, where a top-down
      hand runs out of reach).

    **Success:** the towel's centroid (mean of its particle centres) is within `goal_radius` of the
    target's centre in the table plane; and the towel was dragged there by a corner: at some step the hand
    held (`ee.holds`) a corner particle while the centroid had come at least `drag_share` of its start
    distance towards the target (episode memory `dragged`).

    `is_grasped` (reward and observation only): the hand holds a corner particle (`ee.holds`; the
    solver's "scissor" pinch).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.34, 0.2, -0.3, 0.3)  # towel and target centres plus the towel's half diagonal
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("goal_radius", "drag_share", "towel_x_range", "towel_y_range", "towel_max_yaw", "target_distance_range",
              "target_max_bearing")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.towel = cloth.build_cloth(self.scene, "towel", cloth.towel(ROWS, COLS, self.cloth_config.spacing),
                                       self.cloth_config)
        self.corner_ids = self.towel.layout.named["corners"]
        self.target = build_zone_marker(self.scene, "target", self.goal_radius, (0.55, 0.85, 0.55, 1))
        self.corners = [self.towel.spheres[i] for i in self.corner_ids]
        self.memory.value("start_distance")
        self.memory.flag("dragged")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            centre = torch.stack([uniform(b, self.towel_x_range), uniform(b, self.towel_y_range),
                                  torch.full((b,), self.cloth_config.radius)], dim=1)
            yaw = symmetric_deg(b, self.towel_max_yaw)
            self.towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))
            heading = (torch.rand(b) * 2 - 1) * np.deg2rad(self.target_max_bearing)
            drag = uniform(b, self.target_distance_range)
            target = centre + torch.stack([drag * torch.cos(heading), drag * torch.sin(heading), torch.zeros(b)], dim=1)
            target[:, 2] = MARKER_THICKNESS / 2
            self.target.set_pose(Pose.create_from_pq(target))
            self.memory.store("start_distance", self._distance()[env_idx, None], env_idx)

    def centroid(self) -> torch.Tensor:
        """Mean of the towel's particle centres, [B, 3]."""
        return self.towel.positions().mean(dim=1)

    def _distance(self) -> torch.Tensor:
        """From the towel's centroid to the target's centre in the table plane, [B]."""
        return torch.linalg.norm((self.target.pose.p - self.centroid())[:, :2], dim=1)

    def _update_memory(self):
        came = self._distance() <= (1 - self.drag_share) * self.memory["start_distance"][:, 0]
        self.memory.latch("dragged", came & self.ee.holds(self.corners))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, target_pos=self.target.pose.p, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(towel_points=self.towel.positions().flatten(1),
                       centroid_to_target=self.target.pose.p - self.centroid())
        return obs

    def evaluate(self):
        distance, dragged = self._distance(), self.memory["dragged"]
        return {"success": (distance <= self.goal_radius) & dragged, "distance": distance, "dragged": dragged,
                "is_grasped": self.ee.holds(self.corners)}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        corners = self.towel.positions()[:, self.corner_ids]
        reach = torch.linalg.norm(corners - self.ee.tcp().p[:, None], dim=-1).amin(dim=1)
        reward = 1 - torch.tanh(5 * reach) + info["is_grasped"].float()
        reward += 3 * (1 - torch.tanh(5 * info["distance"]))
        reward[info["success"]] = self.max_dense_reward
        return reward
