"""SlideCardToEdgeHand (L2 rigid SX, family PickThinCard): slide a thin card over a stand's edge, clamp it, lift."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import leap_fingertip
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import tilt, yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.tabletop import build_flat_box

from .base import PickThinCardTask

STAND_HALF = (0.12, 0.15)  # the stand's top: 24 cm deep (x), 30 cm wide (y)
STAND_FRICTION = 0.3
FLAT_TILT = np.deg2rad(10)  # the card "lies" on the stand: tilted less than this, its lowest corner on the top
LYING_TOL = 0.004  # m: ... within this of the stand's top


@register_task("SlideCardToEdgeHand")
class SlideCardToEdgeHandEnv(PickThinCardTask):
    """**Task:** a thin plastic card lies flat on a low stand (a box on the table), too thin for the fingers to
    get under it there. Press it with a fingertip and slide it over the stand's far edge until it sticks
    out, then take the overhang in the hand (fingers curled up under it, the palm on it), and lift.

    **Randomisation:** the stand (24 x 30 cm, `stand_height` tall) stands with its far edge (the one away
    from the robot) uniform in x in `stand_edge_x_range`, its centre's y uniform in +-`stand_edge_max_y`; the
    card (`card_length` x `card_width` x `card_thickness`, ~14 g) lies on it with its centre's y within
    +-`card_max_dy` of the stand's (uniform), its far end short of the far edge by a gap uniform in
    `card_gap_range`, yawed uniform in +-`card_max_yaw`.

    **Success:** the card was slid over the edge: at some control step it lay on the stand (tilted by less
    than `FLAT_TILT`, its lowest corner within `LYING_TOL` of the stand's top) with a corner at least
    `min_overhang` beyond the far edge (episode memory `slid_over_edge`); and now (the PickThinCard family rule,
    `PickThinCardTask`) its lowest point is at least `lift_height` above the stand's top and the hand holds it.

    **Level 2:** against Level 1's SX tasks (one grasp of an object standing free, e.g. LiftBottleHand: 2
    stages, power grasp and lift, ~80 steps): a non-prehensile stage first (press a 2 mm card with one
    fingertip, 2 mm into it, and slide it 7-11 cm by the fingertip's friction against the stand's, without
    lifting or turning it away, to a 3-5 cm overhang), then a grasp that exists only because of the slide and
    that no synergy closes: the palm laid on the card's end with the thumb raised out of the way, the index
    and middle fingers hooked in front of the card's end and only then swung down and back round its 2 mm
    edge and up under the overhang; 4 stages (press, slide, clamp, lift), ~120 steps.
    """

    max_dense_reward = 6
    TASK_REGION = (-0.45, -0.05, -0.25, 0.25)
    PARAMS = PickThinCardTask.PARAMS + ("stand_height", "min_overhang", "stand_edge_x_range", "stand_edge_max_y",
                                        "card_gap_range", "card_max_dy", "card_max_yaw")
    # layout ranges: (low, span), or the half width of a range centred on 0

    @property
    def surface_height(self) -> float:
        return self.stand_height

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.stand = build_flat_box(self.scene, "stand", (*STAND_HALF, self.stand_height / 2),
                                    color=(0.35, 0.35, 0.38, 1), friction=STAND_FRICTION, kinematic=True)
        self.memory.flag("slid_over_edge")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            edge = uniform(b, self.stand_edge_x_range)
            stand_y = (torch.rand(b) * 2 - 1) * self.stand_edge_max_y
            stand = torch.stack([edge - STAND_HALF[0], stand_y, torch.full((b,), self.stand_height / 2)], dim=1)
            self.stand.set_pose(Pose.create_from_pq(stand))
            gap = uniform(b, self.card_gap_range)
            card = torch.stack([edge - gap - self.card_length / 2, stand_y + (torch.rand(b) * 2 - 1) * self.card_max_dy,
                                torch.full((b,), self.stand_height + self.card_thickness / 2)], dim=1)
            self.card.set_pose(Pose.create_from_pq(card, yaw_quat((torch.rand(b) * 2 - 1) * np.deg2rad(self.card_max_yaw))))

    def far_edge(self) -> torch.Tensor:
        """(b,) x of the stand's far edge."""
        return self.stand.pose.p[:, 0] + STAND_HALF[0]

    def overhang(self) -> torch.Tensor:
        """(b,) how far (m) the card's farthest corner reaches beyond the stand's far edge (negative: short of it)."""
        return self.card_corners()[..., 0].max(dim=1).values - self.far_edge()

    def lies_on_stand(self) -> torch.Tensor:
        return (self.card_height().abs() <= LYING_TOL) & (tilt(self.card) < FLAT_TILT)

    def _update_memory(self):
        self.memory.latch("slid_over_edge", (self.overhang() >= self.min_overhang) & self.lies_on_stand())

    def task_conditions(self, info: dict) -> torch.Tensor:
        info["slid_over_edge"] = self.memory["slid_over_edge"]
        info["overhang"] = self.overhang()
        return info["slid_over_edge"]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"],
                   slid_over_edge=info["slid_over_edge"])
        if "state" in self.obs_mode:
            obs.update(card_pose=self.card.pose.raw_pose, stand_pos=self.stand.pose.p, overhang=info["overhang"],
                       tcp_to_card=self.card.pose.p - self.ee.tcp().p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # fingertip to the card, the card slid out to the overhang, then held and lifted
        reach = torch.linalg.norm(self.card.pose.p - leap_fingertip(self.agent), dim=1)
        reward = 1 - torch.tanh(5 * reach)
        slid = info["slid_over_edge"].float()
        reward += torch.where(info["slid_over_edge"], torch.ones_like(reach),
                              (info["overhang"] / self.min_overhang).clamp(0, 1))
        reward += slid * (info["is_grasped"].float() + 2 * (info["height"] / self.lift_height).clamp(0, 1)
                          * info["is_grasped"])
        reward[info["success"]] = self.max_dense_reward
        return reward
