"""LiftRopeBimanual (L1 deformable DG): both arms lift a rope by its two ends and hold it taut."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from maniladder_ms.agents.helpers import top_down_quat
from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rope.base import RopeBetweenArmsTask

SIDES = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table


@register_task("LiftRopeBimanual")
class LiftRopeBimanualEnv(RopeBetweenArmsTask, ManiLadderEnv):
    """**Task:** a rope lies across the table between the two arms; each gripper takes one end of it and
    together they lift it and hold it taut in the air.

    **Randomisation:** the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of 1.6 cm diameter) lies flat
    across the table (along y) in a gentle S: the in-plane turn between capsules k and k + 1 is
    amp * sin(2 pi (k + 1) / 20 + phase), amp uniform in [0, 0.15] rad, phase uniform; the mean of its
    capsule centres is at x uniform in [-0.15, -0.05], y uniform in [-0.03, 0.03]; its first capsule
    heads within +-15 degrees (uniform) of +y or of -y.

    **Success:** both rope ends (the outer tips of the end capsules) are at least `lift_height` above the
    table, the distance between them is at least `min_spread` of the rope's length, and each gripper holds
    (`ee.holds`) one of the `end_capsules` outermost capsules at the end on its side (`left_grasped`,
    `right_grasped`: the rope is lifted by both arms, by its ends).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.1, -0.32, 0.32)
    PARAMS = ("lift_height", "min_spread", "end_capsules")

    def end_points(self) -> dict[str, torch.Tensor]:
        """Centres of the two end capsules, keyed by the arm on whose side each lies, [B, 3] each."""
        first, last = self.rope.links[0].pose.p, self.rope.links[-1].pose.p
        first_left = (first[:, 1] >= last[:, 1])[:, None]
        return {"left": torch.where(first_left, first, last), "right": torch.where(first_left, last, first)}

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


GRASP_CLEARANCE = 0.004  # TCP this far above the capsule centre: finger tips off the table, free to close
HOLD_HEIGHT = 0.2  # the grasped end capsules end this high: the tips clear `lift_height` (15 cm)
HOLD_SPREAD = 0.33  # metres between the grasped capsule centres at the end (0.34 between them along the rope)


@register_solver("LiftRopeBimanual", control_modes=TCP_DELTA_MODES)
def solve_lift_rope_bimanual(env, seed: int) -> dict:
    """Each arm takes the second capsule from the end on its side top-down, fingers across the capsule; both close, then
    rise together while moving apart along the line between the ends, to hold the rope nearly straight."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftRopeBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        # the second capsule from each end: a free end capsule turns in the closing fingers and slips out
        first, last = task.rope.links[1], task.rope.links[-2]
        first_left = bool(first.pose.p[0, 1] >= last.pose.p[0, 1])  # one env: the solver's
        links = {"left": first if first_left else last, "right": last if first_left else first}
        grasps = []
        for side in SIDES:
            link = links[side]
            yaw = DrivenSolver.neutral_yaw(rope.segment_yaw(link.pose.q), np.pi)
            p = link.pose.p.clone()
            p[:, 2] = task.rope_config.radius + GRASP_CLEARANCE
            grasps.append(Grasp(f"{side}_arm", f"{side}_gripper", p, top_down_quat(yaw, n, device), above))
        reach(s, grasps)
        grasp_together(s, [g.ee for g in grasps])
        left, right = grasps
        middle = (left.p + right.p) / 2
        across = torch.nn.functional.normalize((left.p - right.p) * torch.tensor([1.0, 1.0, 0.0], device=device), dim=1)
        lift = torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=device) + middle * torch.tensor([1.0, 1.0, 0.0], device=device)
        ends = {"left": lift + across * HOLD_SPREAD / 2, "right": lift - across * HOLD_SPREAD / 2}
        glide(s, {g.arm: (g.p, ends[side], g.q) for side, g in zip(SIDES, grasps)})
        s.hold_until_success()
        return s.info

