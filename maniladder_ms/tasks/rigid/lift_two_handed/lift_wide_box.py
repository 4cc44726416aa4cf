"""LiftWideBox (L1 rigid DG, family LiftTwoHanded): lift an open box too wide for one gripper with both arms."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects import build_tray

from .base import LiftTwoHandedTask


@register_task("LiftWideBox")
class LiftWideBoxEnv(LiftTwoHandedTask):
    """**Task:** lift an open box (a tote) 30-46 cm long, too long for one gripper, with both arms: each
    gripper takes one of its short end walls (the graspable lips) and they lift together.

    **Randomisation:** the box's inner half length is drawn uniform in `inner_half_length_range` at each build of
    the scene (every seeded episode: fresh physics per seed), so where the grippers close follows the box the
    cameras show; its inner half width is `inner_half_width`, its walls `wall_height` high and `wall_thickness`
    thick, open top (0.9-1.3 kg). It lies with its long side across the table (along y), its centre uniform in
    x in `box_x_range`, y in `box_y_range`, its yaw uniform in +-`box_max_yaw` about that.

    **Success:** (the LiftTwoHanded family rule, `LiftTwoHandedTask`) the box bottom is at least
    `lift_height` above the table, the box is tilted by less than `max_tilt` (angle between its up axis and
    the world's), and each gripper holds it (`ee.holds` for the left and the right).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.1, -0.3, 0.3)
    PARAMS = LiftTwoHandedTask.PARAMS + ("inner_half_length_range", "inner_half_width", "wall_height",
                                         "wall_thickness", "box_x_range", "box_y_range", "box_max_yaw")
    base_thickness = 0.008

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        # drawn from the episode's seeded torch RNG (ManiSkill seeds it around a reconfiguration); one box for
        # every sub-scene. inner_half: (long side, along the box's local x; short side)
        self.inner_half = (float(uniform(1, self.inner_half_length_range)), self.inner_half_width)
        self.box = build_tray(self.scene, "box", self.inner_half, self.wall_height, self.wall_thickness,
                              self.base_thickness, color=(0.3, 0.45, 0.75, 1))
        self.item = self.box

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.box_x_range), uniform(b, self.box_y_range), torch.zeros(b)], dim=1)
            yaw = np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.box_max_yaw)
            self.box.set_pose(Pose.create_from_pq(xyz, yaw_quat(yaw)))

    def lip_points(self) -> dict[str, torch.Tensor]:
        """World grasp points on the two end walls (mid-thickness, 2 cm below the top), keyed by the arm
        that takes them: the box's local +x end faces +y, the left arm's side."""
        x = self.inner_half[0] + self.wall_thickness / 2
        points = {}
        for side, sign in (("left", 1.0), ("right", -1.0)):
            local = Pose.create_from_pq(torch.tensor([[sign * x, 0.0, self.wall_height - 0.02]], device=self.device))
            points[side] = (self.box.pose * local).p
        return points

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            lips = self.lip_points()
            obs.update(box_pose=self.box.pose.raw_pose,
                       left_tcp_to_lip=lips["left"] - self.ee.tcp("left").p,
                       right_tcp_to_lip=lips["right"] - self.ee.tcp("right").p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        lips = self.lip_points()
        reach = sum(1 - torch.tanh(5 * torch.linalg.norm(lips[s] - self.ee.tcp(s).p, dim=1))
                    for s in ("left", "right"))
        both = info["left_grasped"] & info["right_grasped"]
        reward = reach + info["left_grasped"].float() + info["right_grasped"].float()
        # lifting counts only while level, and only with both grippers on the box
        lift = (info["height"] / self.lift_height).clamp(max=1) * (1 - info["tilt"] / np.pi)
        reward += 2 * lift * both
        reward[info["success"]] = self.max_dense_reward
        return reward
