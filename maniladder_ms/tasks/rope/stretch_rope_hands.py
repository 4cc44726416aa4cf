"""StretchRopeHands (L1 deformable DX): both LEAP hands pinch a rope near its ends and stretch it straight."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.tasks.rope.base import RopeBetweenArmsTask


@register_task("StretchRopeHands")
class StretchRopeHandsEnv(RopeBetweenArmsTask, ManiLadderEnv):
    """**Task:** a rope lies across the table between the two arms; each LEAP hand pinches it near one end,
    and together they lift it and stretch it straight in the air.

    **Randomisation** (`RopeBetweenArmsTask`): the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of
    1.6 cm diameter) lies flat across the table (along y) in a gentle S: the in-plane turn between capsules
    k and k + 1 is amp * sin(2 pi (k + 1) / 20 + phase), amp uniform in [0, `rope_max_amp`], phase uniform; the
    mean of its capsule centres is at x uniform in `rope_x_range`, y uniform in `rope_y_range`; its first
    capsule heads within +-`rope_max_yaw` (uniform) of +y or of -y.

    **Success:** the rope's straightness (`rope.straightness`: tip-to-tip distance over arc length) is at
    least `min_straightness`, every point of it (capsule centres and the two tips) is at least `lift_height`
    above the table, and each hand holds (`ee.holds`: the solver's "scissor" pinch, or a finger against the
    thumb or palm) one of the `end_capsules` outermost capsules at the end on its side (`left_grasped`,
    `right_grasped`: the rope is stretched by both hands, not just lying straight on something).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.1, -0.32, 0.32)
    PARAMS = ("min_straightness", "lift_height", "end_capsules") + RopeBetweenArmsTask.ROPE_LAYOUT_PARAMS

    def end_points(self) -> dict[str, torch.Tensor]:
        """Centres of the second capsule from each end (where the solver pinches), keyed by side, [B, 3]."""
        return self.side_points(1)

    def evaluate(self):
        points = self.rope.points()
        straightness = rope.straightness(points)
        lowest = points[..., 2].amin(dim=1)
        straight = straightness >= self.min_straightness
        lifted = lowest >= self.lift_height
        grasped = self.end_holds()
        return {
            "success": straight & lifted & grasped["left"] & grasped["right"],
            "straight": straight,
            "lifted": lifted,
            "straightness": straightness,
            "lowest": lowest,
            "left_grasped": grasped["left"],
            "right_grasped": grasped["right"],
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        return self._two_arm_reward(info, info["lowest"] / self.lift_height, info["straightness"] / self.min_straightness)
