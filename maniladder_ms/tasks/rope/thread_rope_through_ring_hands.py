"""ThreadRopeThroughRingHands (L2 deformable DX): two LEAP hands thread a rope's end through a standing ring."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.layout import uniform
from maniladder_ms.objects.tabletop import build_standing_ring
from maniladder_ms.tasks.rope.base import RopeTask

RING_COLOR = (0.3, 0.32, 0.38, 1)
RING_TUBE = 0.006  # radius of the ring's tube (m)
RING_HEIGHT = 0.06  # the ring's centre above the table: its inner bottom 2.5 cm up, under the rope's feed height
FEED_SIDE = -1.0  # the rope lies on this side (sign of y) of the ring: the right hand feeds, the left pulls
FEED_CAPSULE = 5  # the feeding hand pinches this capsule (0: the end one): 5 capsules (10 cm) stick out beyond it


@register_task("ThreadRopeThroughRingHands")
class ThreadRopeThroughRingHandsEnv(RopeTask, ManiLadderEnv):
    """**Task:** a ring stands upright on a post fixed to the table, its axis across the table (along y); a rope
    lies on the table on the right arm's side of it, its end pointing at the ring. Thread the rope's end through
    the ring and pull it out on the other side, then let go: one hand feeds the end through, the other takes
    it beyond the ring and pulls.

    **Randomisation:** the ring (inner radius `ring_radius`, its centre 6 cm above the table) stands at x
    uniform in `ring_x_range`, y uniform in `ring_y_range`; the rope (40 cm, 20 capsules of 1.6 cm diameter,
    stiffer than the default rope: a cord) lies flat in a gentle S (in-plane turns amp * sin(2 pi (k + 1) / 20
    + phase), amp uniform in [0, `rope_max_amp`], phase uniform) on the right (-y) side of the ring: its first
    tip a gap uniform in `tip_gap_range` from the ring's plane and within +-`tip_max_dx` (uniform) of the
    ring's centre along x, from there it runs away from the ring, its first capsule heading within
    +-`rope_max_yaw` (uniform) of -y.

    **Success:** the rope passes through the ring's disc exactly once (`rope.through_ring` with the ring's inner
    radius `ring_radius`) with at least `min_side` of its length on each side of the crossing; the rope was
    pulled through (`pulled_through`, episode memory: at some step a hand held (`ee.holds`) a capsule lying
    at least `min_side` beyond the ring's plane on the far side (the side away from where the rope started)
    while the rope passed through the ring), so a push alone or a dropped rope does not count; and no hand
    touches the rope (`ee.touches`): it stays threaded by itself.

    **Level 2:** (against Level 1's StretchRopeHands: 2 stages, both hands pinch and lift, horizon 150, T ~ 20):
    6 stages across both arms (pinch, lift and feed, lay on the ring and let go, pinch on the far side, pull
    through, lay down and let go) around a fixed obstacle: the right hand pinches the rope 11 cm from its end,
    lifts it to 2 cm above the centre of a ring 7 cm across and feeds the end along the ring's axis, its
    fingertips stopping ~1.5 cm short of the 1.2 cm tube so that ~8 cm of cord stick out beyond it; the LEAP
    hands (palms ~13 cm long, the curled ring finger reaching 8 cm ahead of the pinch) cannot both hold the rope
    within a few cm of the ring, so the feeder lays the rope on the ring's bottom and lets go and the left hand
    takes the protruding end where it came to rest, its fingers 1-3 cm from the ring, then pulls ~12 cm through;
    a fed end that misses the ring's opening, slips back out or is pushed but not pulled fails.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.1, -0.52, 0.32)  # the rope lies up to 51 cm right (-y) of the ring
    PARAMS = ("ring_radius", "min_side", "ring_x_range", "ring_y_range", "rope_max_yaw", "tip_gap_range", "tip_max_dx",
              "rope_max_amp")
    # a cord 40 times stiffer in bending than the default rope: the end the feeding hand holds out (5 capsules
    # beyond the pinch) must stay roughly straight to enter the ring (the default rope's end hangs straight down;
    # at 10x it drooped 4.5 cm over 8 cm and poked only 1.5 cm through)
    rope_config = rope.RopeConfig(bend_stiffness=0.08, bend_damping=0.016)

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the rope (RopeTask)
        self.ring = build_standing_ring(self.scene, "ring", self.ring_radius, RING_TUBE, RING_HEIGHT, RING_COLOR)
        self.memory.flag("pulled_through")
        self.memory.value("start_side", 1)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            ring = torch.stack([uniform(b, self.ring_x_range), uniform(b, self.ring_y_range), torch.zeros(b)], dim=1)
            self.ring.set_pose(Pose.create_from_pq(ring))
            heading = FEED_SIDE * np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.rope_max_yaw)
            gap = uniform(b, self.tip_gap_range)
            tip = torch.stack([ring[:, 0] + (torch.rand(b) * 2 - 1) * self.tip_max_dx, ring[:, 1] + FEED_SIDE * gap],
                              dim=1)
            turns = rope.wavy_turns(b, self.rope_config.segments, np.deg2rad(self.rope_max_amp))
            self.rope.lay_flat(tip, heading, turns, from_tip=True)
            self.memory.store("start_side", torch.full((b, 1), FEED_SIDE), env_idx)

    def ring_frame(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The ring's centre and unit axis, [B, 3] each."""
        pose = self.ring.pose
        centre = pose.p + torch.tensor([0.0, 0.0, RING_HEIGHT], device=self.device)
        axis = torch.tensor([0.0, 1.0, 0.0], device=self.device).expand_as(centre)
        return centre, axis

    def _threading(self):
        points = self.rope.points()
        centre, axis = self.ring_frame()
        count, shorter = rope.through_ring(points, centre, axis, self.ring_radius)
        # how far beyond the ring's plane, on the far side, each capsule lies [B, segments]
        beyond = -((points[:, 1:-1] - centre[:, None]) * axis[:, None]).sum(-1) * self.memory["start_side"]
        return count, shorter, beyond

    def _far_hold(self, beyond: torch.Tensor) -> torch.Tensor:
        """(B,) bool: a hand holds a capsule lying at least `min_side` beyond the ring on the far side."""
        held = torch.zeros(beyond.shape[0], dtype=torch.bool, device=self.device)
        for i, link in enumerate(self.rope.links):
            far = beyond[:, i] >= self.min_side
            if far.any():
                held |= far & self.ee.holds(link)
        return held

    def _update_memory(self):
        count, _, beyond = self._threading()
        self.memory.latch("pulled_through", (count == 1) & self._far_hold(beyond))

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in ("left", "right")}
        obs.update(pulled_through=info["pulled_through"])
        if "state" in self.obs_mode:
            centre, axis = self.ring_frame()
            obs.update(rope_points=self.rope.points().flatten(1), ring_centre=centre, ring_axis=axis)
        return obs

    def evaluate(self):
        count, shorter, _ = self._threading()
        info = dict(crossings=count, shorter_side=shorter, threaded=(count == 1) & (shorter >= self.min_side),
                    pulled_through=self.memory["pulled_through"], touching_rope=self.ee.touches(self.rope.links))
        info["success"] = info["threaded"] & info["pulled_through"] & ~info["touching_rope"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        end = self.rope.links[0].pose.p
        centre, _ = self.ring_frame()
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.rope.links[FEED_CAPSULE].pose.p - self.ee.tcp("right").p, dim=1))
        to_ring = 1 - torch.tanh(5 * torch.linalg.norm(end - centre, dim=1))
        through = (info["crossings"] == 1).float() * (1 + (info["shorter_side"] / self.min_side).clamp(0, 1))
        reward = reach + to_ring + through + info["pulled_through"].float()
        reward = reward + (info["threaded"] & info["pulled_through"] & ~info["touching_rope"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
