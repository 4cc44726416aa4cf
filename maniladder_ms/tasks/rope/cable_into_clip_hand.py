"""CableIntoClipHand (L2 deformable SX): the LEAP hand lays a cable into a U-shaped clip's slot and presses it home."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.clip import build_clip
from maniladder_ms.tasks.rope.base import RopeTask


@register_task("CableIntoClipHand")
class CableIntoClipHandEnv(RopeTask, ManiLadderEnv):
    """**Task:** a cable lies on the table and beside it a short U-shaped clip is fixed to the table; pinch the
    cable with the LEAP hand, lift it over the clip, lay it along the clip's slot, let go and press it down into
    the slot with the fingers, then take the hand away.

    **Randomisation:** the cable (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter, both ends free)
    lies flat in a gentle S (the in-plane turn between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 20 +
    phase), amp uniform in [0, `rope_max_amp`], phase uniform), the mean of its capsule centres at x uniform in
    `rope_x_range`, y uniform in `rope_y_range`, its first capsule's heading uniform in `rope_yaw_range`; the
    clip (a 4 mm base plate and two 8 mm thick walls, `slot_width` apart, `clip_depth` high above the plate and
    `clip_length` long, open at both ends) has its centre on the table a distance uniform in `clip_gap_range` to
    the left of the cable's middle capsule (index 10), seen along that capsule's heading (a negative gap: to its
    right), at right angles to the heading, and its axis within +-`clip_max_yaw` (uniform) of that heading.

    **Success:** at least `min_segments` of the cable's capsules lie inside the clip's slot (`metrics.
    inside_channel_fraction` times the capsule count: the capsule's centre between the walls, at most half of
    `slot_width` from the slot's axis sideways, between the clip's ends (`clip_length` long), and below the walls' top, `clip_depth`
    above the slot's floor); the hand does not touch the cable (`ee.touches`: let go); and earlier in the episode
    the hand touched the cable while at least `min_segments` of its capsules lay in the slot (episode memory
    `pressed`: the cable was pressed home by the hand, not left to fall in).

    `is_grasped` (reward and observation only): the hand holds (`ee.holds`) the cable's middle capsule or one
    of its two neighbours.

    **Level 2:** (against Level 1's LiftRopeHand on the same cable and hand: 2 stages, pinch the middle capsule
    and lift half the rope 10 cm, no placement tolerance, ~90 steps) 5 stages (pinch; lift 3 cm and carry the
    cable 9-12 cm sideways; turn it up to 20 degrees onto the clip's axis and lower it over the slot; let go; press
    it home and withdraw) in ~200 steps. The slot is 19 mm wide for the 16 mm cable: 1.5 mm to spare on each
    side, so over the clip's 6 cm the cable must lie within ~3 degrees of its axis; the walls are only 12 mm
    high, the cable's centre must end below their top (a capsule resting on a wall top lies 8 mm above it), and
    the spread fingertips that pinch the cable are wider than the slot, so it is let go just above the walls and
    pressed in with the fingers closed; 3 capsules, the whole of the clip's length, must end inside.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 6
    # cable and clip: the cable's middle within x [-0.14, -0.06], |y| <= 0.07, its tips up to 20 cm further,
    # the clip up to 12 cm (and its 3.5 cm half length) beyond the middle
    TASK_REGION = (-0.4, 0.2, -0.35, 0.35)
    PARAMS = ("min_segments", "slot_width", "clip_depth", "clip_length", "rope_x_range", "rope_y_range",
              "rope_yaw_range", "rope_max_amp", "clip_gap_range", "clip_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the cable (RopeTask)
        self.clip = build_clip(self.scene, "clip", self.slot_width, self.clip_depth, self.clip_length)
        self.memory.flag("pressed")  # the hand touched the cable while it lay in the slot

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            centres = self.lay_wavy(b)
            k = self.grasp_segment
            along = centres[:, k + 1, :2] - centres[:, k - 1, :2]
            yaw = torch.atan2(along[:, 1], along[:, 0])
            gap = uniform(b, self.clip_gap_range)
            left = torch.stack([-torch.sin(yaw), torch.cos(yaw)], dim=1)  # the capsule's heading turned +90 degrees
            xy = centres[:, k, :2] + gap[:, None] * left
            axis = yaw + (torch.rand(b) * 2 - 1) * np.deg2rad(self.clip_max_yaw)
            self.clip.set_pose(Pose.create_from_pq(torch.cat([xy, torch.zeros(b, 1)], dim=1), yaw_quat(axis)))

    def inside_count(self) -> torch.Tensor:
        """Number of the cable's capsules inside the clip's slot, [B] (float)."""
        return self.clip.inside_fraction(self.rope.points()[:, 1:-1]) * self.rope_config.segments

    def _update_memory(self):
        seated = self.inside_count() >= self.min_segments
        self.memory.latch("pressed", seated & self.ee.touches(self.rope.links))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1), clip_pose=self.clip.pose.raw_pose,
                       inside_count=info["inside_count"],
                       tcp_to_grasp_segment=self.rope.links[self.grasp_segment].pose.p - self.ee.tcp().p)
        return obs

    def evaluate(self):
        count = self.inside_count()
        seated = count >= self.min_segments
        touched = self.ee.touches(self.rope.links)
        k = self.grasp_segment
        pressed = self.memory["pressed"]
        # the middle capsule's distance from the slot's axis line (top-down), for the reward
        off_axis = self.clip.off_axis(self.rope.links[k].pose.p[:, None])[:, 0]
        return {
            "success": seated & ~touched & pressed,
            "inside_count": count,
            "seated": seated,
            "pressed": pressed,
            "touching_cable": touched,
            "off_axis": off_axis,
            "is_grasped": self.ee.holds(self.rope.links[k - 1:k + 2]),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        target = self.rope.links[self.grasp_segment].pose.p
        reach = 1 - torch.tanh(5 * torch.linalg.norm(target - self.ee.tcp().p, dim=1))
        near_axis = 1 - torch.tanh(10 * info["off_axis"])
        inside = (info["inside_count"] / self.min_segments).clamp(0, 1)
        reward = reach + info["is_grasped"].float() + near_axis + inside + info["pressed"].float()
        reward = reward + (info["pressed"] & ~info["touching_cable"]).float() * inside
        reward[info["success"]] = self.max_dense_reward
        return reward
