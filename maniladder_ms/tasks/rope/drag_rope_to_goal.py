"""DragRopeToGoal (L1 deformable SG): grasp a rope near its middle and drag it into a goal zone."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.solvers import register_solver
from maniladder_ms.solvers.panda import PandaSolver
from maniladder_ms.tasks.rope.base import RopeTask


@register_task("DragRopeToGoal")
class DragRopeToGoalEnv(RopeTask, ManiLadderEnv):
    """**Task:** a rope lies on the table on one side of the robot's centre line, a square goal zone is
    marked on the other side; grasp the rope near its middle and drag the whole rope into the zone.

    **Randomisation:**
    - the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter) lies flat in a gentle S:
      the in-plane turn between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 20 + phase), amp
      uniform in [0, 0.2] rad, phase uniform; the mean of its capsule centres is at x uniform in
      [-0.12, 0.0], |y| uniform in [0.12, 0.18] on a random side; its first capsule heads within
      +-0.35 rad (uniform) of +x or of -x;
    - the goal zone (a square tile of half side `zone_half`, axis-aligned) is centred at x uniform in
      [-0.1, 0.02], |y| uniform in [0.08, 0.12] on the other side.

    **Success:** at least `min_inside` of the rope's segments (capsule centres) lie inside the zone's
    square footprint and on the table (centre at most `on_table_height` up); and the rope was dragged:
    at some step the gripper held (`ee.holds`) one of the `grip_segments` capsules around the rope's
    middle while the rope's centroid (mean of the capsule centres, in the table plane) had come at least
    `drag_share` of its start distance towards the zone centre (episode memory `dragged`).
    """

    max_dense_reward = 5
    TASK_REGION = (-0.35, 0.25, -0.35, 0.35)
    PARAMS = ("zone_half", "min_inside", "on_table_height", "grip_segments", "drag_share")

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
            side = torch.where(torch.rand(b) < 0.5, -1.0, 1.0)
            turns = rope.wavy_turns(b, cfg.segments, 0.2)
            heading = (torch.rand(b) - 0.5) * 0.7 + torch.where(torch.rand(b) < 0.5, 0.0, np.pi)
            middle = torch.stack([torch.rand(b) * 0.12 - 0.12, side * (0.12 + torch.rand(b) * 0.06)], dim=1)
            self.rope.lay_flat(middle, heading, turns)
            zone = torch.stack([torch.rand(b) * 0.12 - 0.1, -side * (0.08 + torch.rand(b) * 0.04),
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


DRAG_HEIGHT = 0.04  # the grasped middle rides this high; both halves trail on the table
LEAD = 0.07  # the grasp ends this far past the zone centre, so the trailing halves end up centred


@register_solver("DragRopeToGoal")
def solve_drag_rope_to_goal(env, seed: int) -> dict:
    """Grasp the middle capsule across its axis, lift it 4 cm, drag it in a straight line to just past the
    zone centre (the halves trail behind into the zone), lower, release, retreat."""
    with PandaSolver.episode(env, seed) as robot:
        task: DragRopeToGoalEnv = env.unwrapped
        link = task.rope.links[task.grasp_segment]
        grip_at = link.pose.p[0].cpu().numpy()
        yaw = robot.closest_grasp_yaw(float(rope.segment_yaw(link.pose.q)[0]) + np.pi / 2)
        grasp = robot.top_down_pose([grip_at[0], grip_at[1], task.rope_config.radius], yaw)
        robot.pick(grasp, lift_height=DRAG_HEIGHT)
        zone = task.zone.pose.p[0].cpu().numpy()
        direction = zone[:2] - grip_at[:2]
        direction /= np.linalg.norm(direction)
        end = zone[:2] + LEAD * direction
        release = robot.top_down_pose([end[0], end[1], task.rope_config.radius + 0.005], yaw)
        robot.place(release, approach_height=DRAG_HEIGHT)
        robot.hold_until_success()
        return robot.info
