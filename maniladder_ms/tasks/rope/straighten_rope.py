"""StraightenRope (L3 deformable SG): straighten a crumpled rope into a line along a strip marked on the table."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import metrics, rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.tasks.rope.base import RopeTask

STRIP_COLOR = (0.55, 0.75, 0.9, 1)


@register_task("StraightenRope")
class StraightenRopeEnv(RopeTask, ManiLadderEnv):
    """**Task:** a rope lies crumpled on the table (bent back and forth in loose meanders and curls), and beyond
    it, away from the robot, a long narrow strip is marked across the table; straighten the rope into a line lying
    along the strip and let go.

    **Randomisation:**
    - the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter) lies flat and crumpled
      (`rope.crumpled_turns`: a meander with a curl, the in-plane turn after capsule k being curl + amp *
      sin(2 pi cycles (k + 1) / 20 + phase) + noise, curl uniform in +-0.15 rad, amp uniform in [0.35, 0.6] rad,
      cycles uniform in [1, 2], phase uniform, noise uniform in +-0.1 rad per joint; redrawn until its straightness
      (`rope.straightness`, as the success rule measures it) is at most `START_STRAIGHTNESS` and no two capsules
      lie closer than `START_CLEARANCE` beyond touching), its first capsule heading uniform in all directions, the
      mean of its capsule centres at x uniform in [`ROPE_X_LOW`, `ROPE_X_LOW` + `ROPE_X_SPAN`], y uniform in
      [-`ROPE_ABS_Y`, `ROPE_ABS_Y`];
    - the strip (`strip_length` by `strip_width`, a flat marker) has its centre at x uniform in [`STRIP_X_LOW`,
      `STRIP_X_LOW` + `STRIP_X_SPAN`], y uniform in [-`STRIP_ABS_Y`, `STRIP_ABS_Y`], its long axis within
      +-`STRIP_TURN` (uniform) of the y axis.

    **Success:** the rope is straight (`rope.straightness`, its tip-to-tip distance over its arc length, at least
    `min_straightness`); at least `min_inside` of its capsule centres lie inside the strip and on the table
    (`metrics.inside_channel_fraction`: at most half of `strip_width` from the strip's axis sideways, at most half
    of `strip_length` from its centre along it, at most `on_table_height` up); and the rope is let go (the
    gripper does not touch it, `ee.touches`), so it lies straight by itself.

    **Level 3:** (against Level 2's WrapRopeAroundPost: one rope end anchored, 4 stages, ~170 steps, a winding
    count with no placement tolerance; and Level 1's DragRopeToGoal: 2 stages, one straight drag of 40 cm of rope
    into a 22 cm square): the rope starts crumpled (straightness at most 60%, about half at the median) and free at
    both ends, and a rope dragged over the table by one end keeps a bow that friction holds (a 40 cm rope bowed 3.5
    cm off its chord is still 97.7% straight): the rope has to be pulled from both ends in turn. 9 stages (grasp an
    end; drag it to the strip's near end; let go; grasp the other end; swing it round the first on a 30 cm circle
    onto the strip's axis, the held capsule turned to point along the pull, else it pivots in the fingers and
    slips out; pull it along the axis until taut; let go; take the first end again and pull it back along the
    axis, dragging the whole rope straight; let go), ~360 steps, the hand travelling over 1 m. The rope must end
    95% straight (tip to tip at least 38 of its 40 cm) with 18 of its 20 capsules within a 5 cm wide strip (1.7 cm
    to spare on each side of the 1.6 cm rope: a bow of more than ~2.5 cm fails) whose 46 cm leave 3 cm at each end
    of the rope, and it has to stay so once let go.
    """

    max_dense_reward = 7
    # x from -0.42: a rope at the far corner of its draw reaches 13 cm beyond its centroid; y +-0.45: the strip's
    # ends reach y = +-0.33 at the extremes of its draw, and the solver pulls the rope past them
    TASK_REGION = (-0.42, 0.25, -0.45, 0.45)
    PARAMS = ("min_straightness", "min_inside", "strip_width", "strip_length", "on_table_height")
    START_STRAIGHTNESS = 0.6  # the crumpled rope's straightness at reset is at most this
    START_CLEARANCE = 0.004  # m: capsules laid at least this far apart beyond touching
    ROPE_X_LOW, ROPE_X_SPAN = -0.25, 0.08  # the rope's centroid x: uniform in [low, low + span]
    ROPE_ABS_Y = 0.08  # the rope's centroid y: uniform in [-abs, abs]
    STRIP_X_LOW, STRIP_X_SPAN = 0.0, 0.06  # the strip centre's x
    STRIP_ABS_Y = 0.04  # the strip centre's y: uniform in [-abs, abs]
    STRIP_TURN = np.deg2rad(15)  # the strip's axis lies within this of the y axis

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the rope (RopeTask)
        self.strip = build_zone_marker(self.scene, "strip", (self.strip_length / 2, self.strip_width / 2), STRIP_COLOR)
        self.memory.value("strip_yaw")  # the strip's axis (the marker's yaw), kept so evaluate needs no quaternion

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            turns = rope.crumpled_turns(b, self.rope_config, self.START_STRAIGHTNESS, self.START_CLEARANCE)
            heading = torch.rand(b) * 2 * np.pi
            middle = torch.stack([self.ROPE_X_LOW + torch.rand(b) * self.ROPE_X_SPAN,
                                  (torch.rand(b) * 2 - 1) * self.ROPE_ABS_Y], dim=1)
            self.rope.lay_flat(middle, heading, turns)
            yaw = np.pi / 2 + (torch.rand(b) * 2 - 1) * self.STRIP_TURN
            centre = torch.stack([self.STRIP_X_LOW + torch.rand(b) * self.STRIP_X_SPAN,
                                  (torch.rand(b) * 2 - 1) * self.STRIP_ABS_Y,
                                  torch.full((b,), MARKER_THICKNESS / 2)], dim=1)
            self.strip.set_pose(Pose.create_from_pq(centre, yaw_quat(yaw)))
            self.memory.store("strip_yaw", yaw[:, None], env_idx)

    def end_links(self) -> tuple:
        """The capsules at the rope's two ends (first, last)."""
        return self.rope.links[0], self.rope.links[-1]

    def strip_frame(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The strip's centre [B, 3] and its axis' yaw [B]."""
        return self.strip.pose.p, self.memory["strip_yaw"][:, 0]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            centre, yaw = self.strip_frame()
            obs.update(rope_points=self.rope.points().flatten(1), strip_pos=centre,
                       strip_axis=torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1))
        return obs

    def evaluate(self):
        points = self.rope.points()
        straightness = rope.straightness(points)
        centre, yaw = self.strip_frame()
        inside = metrics.inside_channel_fraction(points[:, 1:-1], centre, yaw, self.strip_width / 2,
                                                 self.strip_length / 2, self.on_table_height)
        straight = straightness >= self.min_straightness
        in_strip = inside >= self.min_inside
        touched = self.ee.touches(self.rope.links)
        return {
            "success": straight & in_strip & ~touched,
            "straightness": straightness,
            "inside_fraction": inside,
            "straight": straight,
            "in_strip": in_strip,
            "touching_rope": touched,
            "is_grasped": self.ee.holds(list(self.end_links())),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        """Reach the nearer end (1), hold an end (1), straightness (2), share inside the strip (2), both met
        and let go (1); `max_dense_reward` on success."""
        tcp = self.ee.tcp().p
        reach = torch.stack([torch.linalg.norm(link.pose.p - tcp, dim=1) for link in self.end_links()]).amin(dim=0)
        reward = 1 - torch.tanh(5 * reach)
        reward = torch.where(info["is_grasped"], 1.0, reward) + info["is_grasped"].float()
        reward = reward + 2 * info["straightness"] + 2 * info["inside_fraction"]
        reward = reward + (info["straight"] & info["in_strip"] & ~info["touching_rope"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
