"""StretchRopeHands (L1 deformable DX): both LEAP hands pinch a rope near its ends and stretch it straight."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.rope.base import RopeBetweenArmsTask

SIDES = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table


@register_task("StretchRopeHands")
class StretchRopeHandsEnv(RopeBetweenArmsTask, ManiLadderEnv):
    """**Task:** a rope lies across the table between the two arms; each LEAP hand pinches it near one end,
    and together they lift it and stretch it straight in the air.

    **Randomisation** (`RopeBetweenArmsTask`): the rope (`rope.RopeConfig()`: 40 cm, 20 capsules of
    1.6 cm diameter) lies flat across the table (along y) in a gentle S: the in-plane turn between capsules
    k and k + 1 is amp * sin(2 pi (k + 1) / 20 + phase), amp uniform in [0, 0.15] rad, phase uniform; the mean of its
    capsule centres is at x uniform in [-0.15, -0.05], y uniform in [-0.03, 0.03]; its first capsule
    heads within +-15 degrees (uniform) of +y or of -y.

    **Success:** the rope's straightness (`rope.straightness`: tip-to-tip distance over arc length) is at
    least `min_straightness`, every point of it (capsule centres and the two tips) is at least `lift_height`
    above the table, and each hand holds (`ee.holds`: the solver's "scissor" pinch, or a finger against the
    thumb or palm) one of the `end_capsules` outermost capsules at the end on its side (`left_grasped`,
    `right_grasped`: the rope is stretched by both hands, not just lying straight on something).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.1, -0.32, 0.32)
    PARAMS = ("min_straightness", "lift_height", "end_capsules")

    def end_points(self) -> dict[str, torch.Tensor]:
        """Centres of the second capsule from each end (where the solver pinches), keyed by side, [B, 3]."""
        first, last = self.rope.links[1].pose.p, self.rope.links[-2].pose.p
        left_first = self.first_is_left()[:, None]
        return {"left": torch.where(left_first, first, last), "right": torch.where(left_first, last, first)}

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


LIFT_STEP = 0.006  # metres a control step, as LiftRopeHand's lift: faster swings the rope out of the pinch
HOLD_HEIGHT = 0.15  # the pinched capsules end this high: the sagging rope and its hanging ends clear `lift_height` (5 cm)
HOLD_SPREAD = 0.335  # metres between the pinched capsule centres at the end (0.34 between them along the rope)


@register_solver("StretchRopeHands", control_modes=TCP_DELTA_MODES)
def solve_stretch_rope_hands(env, seed: int) -> dict:
    """Each hand takes the second capsule from the end on its side in the "scissor" pinch (fingers along the
    rope), both close together, then rise together while moving apart along the line between the ends."""
    with DrivenSolver.episode(env, seed) as s:
        task: StretchRopeHandsEnv = env.unwrapped
        device = task.device
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        first, last = task.rope.links[1], task.rope.links[-2]
        left_first = bool(task.first_is_left()[0])  # one env: the solver's
        links = {"left": first if left_first else last, "right": last if left_first else first}
        grasps, centres = [], {}
        for side in SIDES:
            link = links[side]
            centre = link.pose.p.clone()
            centre[:, 2] = task.rope_config.radius
            centres[side] = centre
            p, q = DrivenSolver.scissor_pose(centre, rope.segment_yaw(link.pose.q), mirror=side == "left")
            grasps.append(Grasp(f"{side}_arm", f"{side}_hand", p, q, above))
        for g in grasps:
            s.set_ee(g.ee, "scissor_open", steps=0)
        reach(s, grasps, preshape=None)
        grasp_together(s, [g.ee for g in grasps], "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        left, right = grasps
        middle = (left.p + right.p) / 2
        flat = torch.tensor([1.0, 1.0, 0.0], device=device)
        across = torch.nn.functional.normalize((left.p - right.p) * flat, dim=1)
        lift = torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=device) + middle * flat
        ends = {"left": lift + across * HOLD_SPREAD / 2, "right": lift - across * HOLD_SPREAD / 2}
        # each tcp moves as its capsule should
        glide(s, {g.arm: (g.p, g.p + ends[side] - centres[side], g.q) for side, g in zip(SIDES, grasps)},
              step_length=LIFT_STEP)
        s.hold_until_success()
        return s.info
