"""The PickThinCard family's base (SlideCardToEdgeHand, Level 2; PickThinCardHand, Level 3): a thin card lies flat,
too thin for any hand to get under it where it lies, and must end up lifted in the hand.

The family base `PickThinCardTask` builds the card from the catalog params and holds the rule, `evaluate`,
once; the task classes build what the card lies on (`surface_height`: its top above the table), place the
card, and add their own conditions (`task_conditions`: how the card was got off its surface). Their solvers are
in `maniladder_ms/solvers/rigid/pick_thin_card/`.
"""

from __future__ import annotations

import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.objects.tabletop import build_flat_box

CARD_DENSITY = 1200.0  # kg/m^3, a plastic card
CARD_FRICTION = 0.3  # the card's surfaces (a fingertip's rubber grips it: 2.0 and 0.3 average to 1.15)


class PickThinCardTask(ManiLadderEnv):
    """Family base (registers no task). **Success:** the card's lowest point is at least `lift_height` above
    the top of the surface it lay on, the hand holds it (`ee.holds`: a finger pressing against the thumb or
    palm, or the index / middle scissor pinch), and the task's own conditions hold (`task_conditions`).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    PARAMS = ("card_length", "card_width", "card_thickness", "lift_height")
    surface_height = 0.0  # top of what the card lies on, above the table top

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.card = build_flat_box(self.scene, "card", (self.card_length / 2, self.card_width / 2,
                                                        self.card_thickness / 2),
                                   color=(0.15, 0.35, 0.8, 1), density=CARD_DENSITY, friction=CARD_FRICTION)

    def card_corners(self) -> torch.Tensor:
        """(b, 4, 3) world positions of the card's four corners, on its mid-plane."""
        x, y = self.card_length / 2, self.card_width / 2
        local = torch.tensor([[x, y, 0.0], [x, -y, 0.0], [-x, y, 0.0], [-x, -y, 0.0]], device=self.device)
        q = self.card.pose.q[:, None].expand(-1, 4, 4)
        return self.card.pose.p[:, None] + quaternion_apply(q, local[None].expand(q.shape[0], 4, 3))

    def card_height(self) -> torch.Tensor:
        """(b,) height of the card's lowest corner (its mid-plane less half its thickness) above the surface's top."""
        return self.card_corners()[..., 2].min(dim=1).values - self.card_thickness / 2 - self.surface_height

    def task_conditions(self, info: dict) -> torch.Tensor:
        """(b,) bool: what the task adds to the family rule (all True by default); may add flags to `info`."""
        return torch.ones(self.num_envs, dtype=torch.bool, device=self.device)

    def evaluate(self):
        height = self.card_height()
        is_lifted = height >= self.lift_height
        is_grasped = self.ee.holds(self.card)
        info = dict(height=height, is_lifted=is_lifted, is_grasped=is_grasped)
        info["success"] = is_lifted & is_grasped & self.task_conditions(info)
        return info
