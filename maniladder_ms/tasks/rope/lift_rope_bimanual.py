"""LiftRopeBimanual (L1 deformable DG): both arms lift a rope by its two ends and hold it taut."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.tasks.rope.base import RopeBetweenArmsTask


@register_task("LiftRopeBimanual")
class LiftRopeBimanualEnv(RopeBetweenArmsTask, ManiLadderEnv):
    """**Task:** a rope lies across the table between the two arms; each gripper takes one end of it and
    together they lift it and hold it taut in the air.

    **Randomisation:** the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter) lies flat
    across the table (along y) in a gentle S: the in-plane turn between capsules k and k + 1 is
    amp * sin(2 pi (k + 1) / 20 + phase), amp uniform in [0, `rope_max_amp`], phase uniform; the mean of its
    capsule centres is at x uniform in `rope_x_range`, y uniform in `rope_y_range`; its first capsule heads
    within +-`rope_max_yaw` (uniform) of +y or of -y.

    **Success:** both rope ends (the outer tips of the end capsules) are at least `lift_height` above the
    table, the distance between them is at least `min_spread` of the rope's length, and each gripper holds
    (`ee.holds`) one of the `end_capsules` outermost capsules at the end on its side (`left_grasped`,
    `right_grasped`: the rope is lifted by both arms, by its ends).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.1, -0.32, 0.32)
    PARAMS = ("lift_height", "min_spread", "end_capsules") + RopeBetweenArmsTask.ROPE_LAYOUT_PARAMS

    def end_points(self) -> dict[str, torch.Tensor]:
        """Centres of the two end capsules, keyed by the arm on whose side each lies, [B, 3] each."""
        return self.side_points(0)

    def evaluate(self):
        points = self.rope.points()
        ends_height = torch.minimum(points[:, 0, 2], points[:, -1, 2])
        spread = rope.end_to_end_distance(points) / self.rope_config.length
        lifted = ends_height >= self.lift_height
        taut = spread >= self.min_spread
        grasped = self.end_holds()
        return {
            "success": lifted & taut & grasped["left"] & grasped["right"],
            "lifted": lifted,
            "taut": taut,
            "ends_height": ends_height,
            "spread": spread,
            "left_grasped": grasped["left"],
            "right_grasped": grasped["right"],
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        return self._two_arm_reward(info, info["ends_height"] / self.lift_height, info["spread"] / self.min_spread)
