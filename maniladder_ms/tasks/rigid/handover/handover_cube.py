"""HandoverCube (L1 rigid DG, family Handover): a cube passed from the left gripper to the right, set down in a zone."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.building import actors
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker

from .base import HandoverTask


@register_task("HandoverCube")
class HandoverCubeEnv(HandoverTask):
    """**Task:** the left arm picks up a cube on the left of the table and hands it over to the right arm
    in mid-air; the right arm puts it down in a square target zone on the right.

    **Randomisation:**
    - the cube (side 2 x `cube_half`) lies with its yaw uniform in `cube_yaw_range` (a cube's distinct yaws span 90
      degrees), its centre uniform in x in `cube_x_range`, y in `cube_y_range` (in front of the left arm);
    - the target zone (visual-only square tile, side 2 x `zone_half`, axis-aligned) has its centre uniform in
      x in `zone_x_range`, y in `zone_y_range` (in front of the right arm).

    **Success:** (the Handover family rule, `HandoverTask`) the cube was handed over: the right gripper held
    it (`ee.holds`) while the left gripper neither held nor touched it and its centre was at least
    `lift_height` above the table, after the left gripper had held it (episode memory `handed_over`); and
    now the cube centre lies inside the zone's square (|dx|, |dy| <= `zone_half`), the cube rests on the
    table (centre less than `on_table_tol` above `cube_half`) and neither gripper touches it (`ee.touches`).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 9
    TASK_REGION = (-0.25, 0.1, -0.4, 0.4)
    PARAMS = HandoverTask.PARAMS + ("cube_half", "zone_half", "on_table_tol", "cube_x_range", "cube_y_range",
                                    "cube_yaw_range", "zone_x_range", "zone_y_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.cube = actors.build_cube(self.scene, half_size=self.cube_half, color=(0.85, 0.2, 0.15, 1), name="cube",
                                      initial_pose=Pose.create_from_pq([0, 0.2, self.cube_half]).sp)
        self.zone = build_zone_marker(self.scene, "target_zone", self.zone_half, (0.2, 0.7, 0.3, 1))
        self.item, self.target = self.cube, self.zone

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            cube_xyz = torch.stack([uniform(b, self.cube_x_range), uniform(b, self.cube_y_range),
                                    torch.full((b,), self.cube_half)], dim=1)
            self.cube.set_pose(Pose.create_from_pq(cube_xyz, yaw_quat(uniform_deg(b, self.cube_yaw_range))))
            zone_xyz = torch.stack([uniform(b, self.zone_x_range), uniform(b, self.zone_y_range),
                                    torch.full((b,), MARKER_THICKNESS / 2)], dim=1)
            self.zone.set_pose(Pose.create_from_pq(zone_xyz))

    def item_rest_height(self) -> float:
        return self.cube_half

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            obs.update(cube_pose=self.cube.pose.raw_pose, zone_pos=self.zone.pose.p,
                       cube_to_zone_pos=self.zone.pose.p - self.cube.pose.p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        cube_p = self.cube.pose.p
        left_reach = torch.linalg.norm(cube_p - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(cube_p - self.ee.tcp("right").p, dim=1)
        to_zone = torch.linalg.norm(self.zone.pose.p[:, :2] - cube_p[:, :2], dim=1)
        left_grasped, right_grasped = info["left_grasped"].float(), info["right_grasped"].float()
        # stages: left reaches and grasps; the right reaches the held cube and takes it; the right carries
        # it to the zone and lets go
        reward = (1 - torch.tanh(5 * left_reach)) + left_grasped
        reward = torch.where(left_grasped.bool() | right_grasped.bool(), reward.clamp(min=2), reward)
        reward += (1 - torch.tanh(5 * right_reach)) * left_grasped + 2 * right_grasped
        reward = torch.where(right_grasped.bool(), 5 + (1 - torch.tanh(5 * to_zone)), reward)
        reward = torch.where(info["placed"], 7 + (1 - right_grasped), reward)
        reward[info["success"]] = self.max_dense_reward
        return reward
