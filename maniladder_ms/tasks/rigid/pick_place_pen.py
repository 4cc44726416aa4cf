"""PickPlacePen (L1 rigid SG): pick a pen lying on the table and place it inside a tray."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform, uniform_deg
from maniladder_ms.objects import build_pen, build_tray


@register_task("PickPlacePen")
class PickPlacePenEnv(ManiLadderEnv):
    """**Task:** pick up a pen lying on the table and put it down inside an open tray.

    **Randomisation:**
    - the pen (`pen_length` long, 2 x `pen_radius` thick) lies flat, its yaw uniform in `pen_yaw_range`, its centre
      uniform in x in `pen_x_range`, y in `pen_y_range` (the robot's left);
    - the tray (inner 2 x `tray_inner_half`, walls `tray_wall_height` high) stands on the robot's right, centre x in
      `tray_x_range`, y in `tray_y_range`, yaw uniform in +-`tray_max_yaw`.

    **Success:** the pen centre, in the tray's frame, lies inside the tray's inner footprint shrunk by
    `margin` on every side; the pen centre is below the rim (top of the walls); and the gripper does not
    hold it (`ee.holds`).
    """

    max_dense_reward = 6

    TASK_REGION = (-0.25, 0.24, -0.32, 0.32)
    PARAMS = ("pen_length", "pen_radius", "tray_inner_half", "tray_wall_height", "margin",
              "pen_x_range", "pen_y_range", "pen_yaw_range", "tray_x_range", "tray_y_range", "tray_max_yaw")
    tray_wall_thickness = 0.008
    tray_base_thickness = 0.006

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.pen = build_pen(
            self.scene, "pen", self.pen_length, self.pen_radius, body_color=(0.1, 0.25, 0.75, 1), cap_color=(0.9, 0.9, 0.9, 1)
        )
        self.tray = build_tray(
            self.scene, "tray", self.tray_inner_half, self.tray_wall_height, self.tray_wall_thickness,
            self.tray_base_thickness, color=(0.85, 0.55, 0.2, 1),
        )

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            pen_xyz = torch.stack([uniform(b, self.pen_x_range), uniform(b, self.pen_y_range),
                                   torch.full((b,), self.pen_radius)], dim=1)
            self.pen.set_pose(Pose.create_from_pq(pen_xyz, yaw_quat(uniform_deg(b, self.pen_yaw_range))))
            tray_xyz = torch.stack([uniform(b, self.tray_x_range), uniform(b, self.tray_y_range),
                                    torch.zeros(b)], dim=1)
            self.tray.set_pose(Pose.create_from_pq(tray_xyz, yaw_quat(symmetric_deg(b, self.tray_max_yaw))))

    def _pen_in_tray_frame(self) -> torch.Tensor:
        return (self.tray.pose.inv() * self.pen.pose).p

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(
                pen_pose=self.pen.pose.raw_pose,
                tray_pose=self.tray.pose.raw_pose,
                tcp_to_pen_pos=self.pen.pose.p - self.ee.tcp().p,
                pen_to_tray_pos=self.tray.pose.p - self.pen.pose.p,
            )
        return obs

    def evaluate(self):
        local = self._pen_in_tray_frame()
        limit = torch.tensor(self.tray_inner_half, device=self.device) - self.margin
        is_over_tray = (local[:, :2].abs() <= limit).all(dim=1)
        is_below_rim = local[:, 2] < self.tray_wall_height
        is_grasped = self.ee.holds(self.pen)
        is_placed = is_over_tray & is_below_rim
        return {
            "success": is_placed & ~is_grasped,
            "is_placed": is_placed,
            "is_over_tray": is_over_tray,
            "is_below_rim": is_below_rim,
            "is_grasped": is_grasped,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        tcp_to_pen = torch.linalg.norm(self.pen.pose.p - self.ee.tcp().p, dim=1)
        reward = 1 - torch.tanh(5 * tcp_to_pen)
        is_grasped = info["is_grasped"]
        reward += is_grasped
        # carry: bring the pen above the tray centre, then down into it
        above_tray = self.tray.pose.p + torch.tensor([0, 0, self.tray_wall_height + 0.03], device=self.device)
        carry = 1 - torch.tanh(5 * torch.linalg.norm(above_tray - self.pen.pose.p, dim=1))
        reward += carry * is_grasped
        reward += 2 * info["is_placed"]
        reward += (info["is_placed"] & ~is_grasped).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
