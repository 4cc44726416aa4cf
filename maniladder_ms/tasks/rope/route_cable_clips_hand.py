"""RouteCableClipsHand (L3 deformable SX): the LEAP hand routes a cable through a row of three U-shaped clips, pressing
it into one clip after the other."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables.clip_route import enter_in_order, row_centres
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform
from maniladder_ms.objects.clip import build_clip
from maniladder_ms.tasks.rope.base import RopeTask

CLIP_COUNT = 3
# the clips from first to last: light, mid and dark blue walls (each on a darker base plate), so the order is seen
CLIP_COLORS = ((0.55, 0.75, 1.0, 1), (0.15, 0.35, 0.75, 1), (0.05, 0.1, 0.35, 1))
CLIP_FLOOR_COLORS = ((0.35, 0.5, 0.7, 1), (0.1, 0.2, 0.45, 1), (0.03, 0.06, 0.2, 1))


@register_task("RouteCableClipsHand")
class RouteCableClipsHandEnv(RopeTask, ManiLadderEnv):
    """**Task:** a cable lies on the table and beside it stands a straight row of three U-shaped clips fixed to the
    table (light, mid and dark blue: the order); with the LEAP hand, press the cable into the first clip's slot,
    then into the second, then into the third, and take the hand away with the cable lying in all three.

    **Randomisation:** the cable (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter, both ends free) lies
    flat in a gentle S (the in-plane turn between capsules k and k + 1 is amp * sin(2 pi (k + 1) / 20 + phase),
    amp uniform in [0, `rope_max_amp`], phase uniform), the mean of its capsule centres at x uniform in
    `rope_x_range`, y uniform in `rope_y_range`, its first capsule's heading uniform in `rope_yaw_range`; the row
    of clips (each as CableIntoClipHand's: a 4 mm base plate and two 8 mm thick walls, `slot_width` apart,
    `clip_depth` high above the plate and `clip_length` long, open at both ends; their centres `clip_spacing`
    apart on the row's line, each clip's axis along the row) has its middle clip's centre a distance uniform in
    `clip_gap_range` to the left of the cable's middle capsule (index 10), seen along that capsule's heading,
    shifted along the heading by up to +-`clip_max_shift` (uniform); the row's line runs within
    +-`clip_max_yaw` (uniform) of that heading, the first clip at the end the cable's first capsule points away
    from (the heading's back end), the last at its front end.

    **Success:** each of the three clips holds at least `min_segments` of the cable's capsules inside its slot
    (`metrics.inside_channel_fraction` times the capsule count: the capsule's centre between the walls, at most
    half of `slot_width` from the slot's axis sideways, between the clip's ends (`clip_length` long), and below
    the walls' top, `clip_depth` above the slot's floor: a capsule lying across or on the walls' top is not
    inside); every clip was entered in order (episode memory `entered_<i>`, one flag a clip,
    `clip_route.enter_in_order`: a clip is entered when the hand touches the cable while at least
    `min_segments` of its capsules lie in that clip's slot and every clip before it has been entered) and the
    order was never broken (memory `order_broken`: no clip ever held `min_segments` capsules before the clip
    ahead of it was entered); and the hand does not touch the cable (`ee.touches`: let go).

    `is_grasped` (reward and observation only): the hand holds (`ee.holds`) any of the cable's capsules.

    **Level 3:** (against Level 2's CableIntoClipHand on the same cable, clip and hand: one clip, 5 stages, ~190
    steps) three clips in a fixed order, 15 stages (pinch, carry, lower and let go, press home, withdraw: once a
    clip) in 600-800 steps (the solver's successes); each clip's slot leaves the 16 mm cable 1.5 mm to spare on
    each side and must hold the whole of its 6 cm length, as Level 2's one, and a cable already pressed into an
    earlier clip must not be pulled out of it while the next is done (3 capsules must stay in each of three clips
    at once, against 3 in one); a clip filled before its turn fails the episode.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 12
    # the cable's middle within x [-0.14, -0.08], |y| <= 0.05, its tips up to 20 cm further; the row's middle up to
    # 14 cm beside it (and 2 cm along) and its outer clips (3 cm half length) 10 cm beyond that along the row
    TASK_REGION = (-0.42, 0.22, -0.35, 0.3)
    PARAMS = ("min_segments", "slot_width", "clip_depth", "clip_length", "clip_spacing", "rope_x_range", "rope_y_range",
              "rope_yaw_range", "rope_max_amp", "clip_gap_range", "clip_max_shift", "clip_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the cable (RopeTask)
        self.clips = [build_clip(self.scene, f"clip_{i}", self.slot_width, self.clip_depth, self.clip_length,
                                 CLIP_COLORS[i], CLIP_FLOOR_COLORS[i]) for i in range(CLIP_COUNT)]
        for i in range(CLIP_COUNT):
            self.memory.flag(f"entered_{i}")  # the hand pressed the cable while it lay in clip i, in its turn
        self.memory.flag("order_broken")  # a clip held the cable before the clip ahead of it was entered

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            centres = self.lay_wavy(b)
            k = self.grasp_segment
            along = centres[:, k + 1, :2] - centres[:, k - 1, :2]
            yaw = torch.atan2(along[:, 1], along[:, 0])
            gap = uniform(b, self.clip_gap_range)
            shift = (torch.rand(b) * 2 - 1) * self.clip_max_shift
            forward = torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)
            left = torch.stack([-torch.sin(yaw), torch.cos(yaw)], dim=1)  # the capsule's heading turned +90 degrees
            row_middle = centres[:, k, :2] + gap[:, None] * left + shift[:, None] * forward
            row_yaw = yaw + symmetric_deg(b, self.clip_max_yaw)
            # the first clip at the heading's back end (row_centres puts clip 0 at the row's -yaw end)
            xy = row_centres(row_middle, row_yaw, self.clip_spacing, CLIP_COUNT)
            for i, clip in enumerate(self.clips):
                clip.set_pose(Pose.create_from_pq(torch.cat([xy[:, i], torch.zeros(b, 1)], dim=1), yaw_quat(row_yaw)))

    def inside_counts(self) -> torch.Tensor:
        """Number of the cable's capsules inside each clip's slot, [B, 3] (float)."""
        centres = self.rope.points()[:, 1:-1]
        n = self.rope_config.segments
        return torch.stack([clip.inside_fraction(centres) * n for clip in self.clips], dim=1)

    def entered(self) -> torch.Tensor:
        """The clips entered so far (episode memory), [B, 3] bool."""
        return torch.stack([self.memory[f"entered_{i}"] for i in range(CLIP_COUNT)], dim=1)

    def _update_memory(self):
        seated = self.inside_counts() >= self.min_segments
        entered, broken = enter_in_order(self.entered(), self.memory["order_broken"], seated,
                                         self.ee.touches(self.rope.links))
        for i in range(CLIP_COUNT):
            self.memory.latch(f"entered_{i}", entered[:, i])
        self.memory.latch("order_broken", broken)

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(rope_points=self.rope.points().flatten(1),
                       clip_poses=torch.cat([clip.pose.raw_pose for clip in self.clips], dim=1),
                       inside_counts=info["inside_counts"], entered=self.entered().float())
        return obs

    def evaluate(self):
        counts = self.inside_counts()
        seated = counts >= self.min_segments
        entered = self.entered()
        broken = self.memory["order_broken"]
        touched = self.ee.touches(self.rope.links)
        return {
            "success": seated.all(dim=1) & entered.all(dim=1) & ~broken & ~touched,
            "inside_counts": counts,
            "seated_count": seated.sum(dim=1),
            "entered_count": entered.sum(dim=1),
            "order_broken": broken,
            "touching_cable": touched,
            "is_grasped": self.ee.holds(self.rope.links),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # 3 a clip entered; within a stage (next clip j): reach the capsule nearest clip j, bring it near clip j's
        # centre, fill clip j; after the last clip: all three seated, then the hand off the cable
        n = info["entered_count"]
        j = n.clamp(max=CLIP_COUNT - 1)
        centres = self.rope.points()[:, 1:-1]
        clip_xy = torch.stack([clip.pose.p[:, :2] for clip in self.clips], dim=1)
        goal = clip_xy[torch.arange(len(j), device=j.device), j]
        dist = torch.linalg.norm(centres[..., :2] - goal[:, None], dim=2)
        nearest, k = dist.min(dim=1)
        target = centres[torch.arange(len(k), device=k.device), k]
        reach = 1 - torch.tanh(5 * torch.linalg.norm(target - self.ee.tcp().p, dim=1))
        near = 1 - torch.tanh(10 * nearest)
        fill = (info["inside_counts"].gather(1, j[:, None])[:, 0] / self.min_segments).clamp(0, 1)
        staged = reach + near + fill
        done = (info["seated_count"] == CLIP_COUNT).float() * (1 + (~info["touching_cable"]).float())
        reward = 3 * n.float() + torch.where(n < CLIP_COUNT, staged, done)
        reward[info["order_broken"]] = 0
        reward[info["success"]] = self.max_dense_reward
        return reward
