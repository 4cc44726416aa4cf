"""DragRopeToGoal (L1 deformable SG): grasp a rope near its middle and drag it into a goal zone."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.layout import symmetric_deg, uniform
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.tasks.rope.base import RopeTask


@register_task("DragRopeToGoal")
class DragRopeToGoalEnv(RopeTask, ManiLadderEnv):
    """**Task:** a rope lies on the table on the robot's left (+y), a square goal zone is marked on its
    right; grasp the rope near its middle and drag the whole rope into the zone.

    **Randomisation:**
    - the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter) lies flat in a gentle S:
      the in-plane turn between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 20 + phase), amp
      uniform in [0, `rope_max_amp`], phase uniform; the mean of its capsule centres is at x uniform in
      `rope_x_range`, y uniform in `rope_y_range` (the robot's left); its first capsule heads within
      +-`rope_max_yaw` (uniform) of +x or of -x;
    - the goal zone (a square tile of half side `zone_half`, axis-aligned) is centred at x uniform in
      `zone_x_range`, y uniform in `zone_y_range` (the robot's right).

    **Success:** at least `min_inside` of the rope's segments (capsule centres) lie inside the zone's
    square footprint and on the table (centre at most `on_table_height` up); and the rope was dragged:
    at some step the gripper held (`ee.holds`) one of the `grip_segments` capsules around the rope's
    middle while the rope's centroid (mean of the capsule centres, in the table plane) had come at least
    `drag_share` of its start distance towards the zone centre (episode memory `dragged`).
    """

    max_dense_reward = 5
    TASK_REGION = (-0.35, 0.25, -0.35, 0.35)
    PARAMS = ("zone_half", "min_inside", "on_table_height", "grip_segments", "drag_share", "rope_x_range",
              "rope_y_range", "rope_max_yaw", "rope_max_amp", "zone_x_range", "zone_y_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the rope (RopeTask)
        self.zone = build_zone_marker(self.scene, "goal_zone", self.zone_half, (0.55, 0.85, 0.55, 1))
        half = self.grip_segments // 2
        self.middle_links = self.rope.links[self.grasp_segment - half:self.grasp_segment + half + 1]
        self.memory.value("start_distance")
        self.memory.flag("dragged")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            cfg = self.rope_config
            turns = rope.wavy_turns(b, cfg.segments, np.deg2rad(self.rope_max_amp))
            heading = symmetric_deg(b, self.rope_max_yaw) + torch.where(torch.rand(b) < 0.5, 0.0, np.pi)
            middle = torch.stack([uniform(b, self.rope_x_range), uniform(b, self.rope_y_range)], dim=1)
            self.rope.lay_flat(middle, heading, turns)
            zone = torch.stack([uniform(b, self.zone_x_range), uniform(b, self.zone_y_range),
                                torch.full((b,), MARKER_THICKNESS / 2)], dim=1)
            self.zone.set_pose(Pose.create_from_pq(zone))
            # lay_flat puts the mean of the capsule centres on `middle`
            self.memory.store("start_distance", torch.linalg.norm(middle - zone[:, :2], dim=1)[:, None], env_idx)

    def _segments(self) -> torch.Tensor:
        """Capsule centres, [B, segments, 3]."""
        return self.rope.points()[:, 1:-1]

    def _centroid_distance(self) -> torch.Tensor:
        """Distance in the table plane from the rope's centroid to the zone centre, [B]."""
        return torch.linalg.norm(self._segments()[..., :2].mean(dim=1) - self.zone.pose.p[:, :2], dim=1)

    def _update_memory(self):
        start = self.memory["start_distance"][:, 0]
        came = self._centroid_distance() <= (1 - self.drag_share) * start
        self.memory.latch("dragged", came & self.ee.holds(self.middle_links))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1), zone_pos=self.zone.pose.p)
        return obs

    def evaluate(self):
        seg = self._segments()
        rel = seg[..., :2] - self.zone.pose.p[:, None, :2]
        inside = (rel.abs() <= self.zone_half).all(dim=-1) & (seg[..., 2] <= self.on_table_height)
        fraction = inside.float().mean(dim=1)
        dragged = self.memory["dragged"]
        return {
            "success": (fraction >= self.min_inside) & dragged,
            "fraction_inside": fraction,
            "dragged": dragged,
            "is_grasped": self.ee.holds(self.rope.links[self.grasp_segment]),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        grip_at = self.rope.links[self.grasp_segment].pose.p
        reward = 1 - torch.tanh(5 * torch.linalg.norm(grip_at - self.ee.tcp().p, dim=1))
        reward += info["is_grasped"]
        centroid = self._segments()[..., :2].mean(dim=1)
        reward += 1 - torch.tanh(5 * torch.linalg.norm(centroid - self.zone.pose.p[:, :2], dim=1))
        reward += 2 * info["fraction_inside"]
        reward[info["success"]] = self.max_dense_reward
        return reward
