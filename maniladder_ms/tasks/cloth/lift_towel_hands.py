"""LiftTowelHands (L1 deformable DX): both LEAP hands lift a towel by two corners until it hangs free."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS

ROWS = COLS = 8
SIDES = ("left", "right")
# the top-down hand yaw each arm reaches the towel's corners with: +-45 degrees from it, either arm stops 2-5 cm
# short of a corner at 14.6 cm height (seed 100), so the towel lies with a diagonal along y
ARM_YAW = {"left": np.pi / 2, "right": -np.pi / 2}
# the towel's yaw range: its hand-to-hand diagonal lies 85-105 degrees from the x axis. With the diagonal under
# 84 degrees the right hand's grasp yaw is past its Panda joint 7 limit (2.90 rad): on seeds 100-119 all 8 such
# towels left that arm 0.2 rad short of the grasp orientation and the demo ran past its horizon
TOWEL_YAW_MIN, TOWEL_YAW_MAX = np.pi / 4 - np.pi / 36, np.pi / 4 + np.pi / 12


def side_corners(layout: cloth.ClothLayout) -> dict[str, int]:
    """The particle index of each hand's corner: the corners furthest left (+y) and right at reset (the
    towel's yaw keeps them the same two: the corners on the diagonal x + y of its own grid)."""
    corners = layout.named["corners"]
    along = [float(layout.positions[i, 0] + layout.positions[i, 1]) for i in corners]
    return {"left": corners[int(np.argmax(along))], "right": corners[int(np.argmin(along))]}


def lay_between_hands(towel: cloth.Cloth, b: int):
    """Lay `towel` flat for `b` envs being reset (in the env's torch device context) as LiftTowelHands does:
    centre x uniform in [-0.14, -0.06], y in [-0.03, 0.03], yaw uniform in [TOWEL_YAW_MIN, TOWEL_YAW_MAX]."""
    centre = torch.stack([torch.rand(b) * 0.08 - 0.14, torch.rand(b) * 0.06 - 0.03,
                          torch.full((b,), towel.config.radius)], dim=1)
    yaw = TOWEL_YAW_MIN + torch.rand(b) * (TOWEL_YAW_MAX - TOWEL_YAW_MIN)
    towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))


@register_task("LiftTowelHands")
class LiftTowelHandsEnv(ManiLadderEnv):
    """**Task:** a towel lies flat on the table between the two arms, one corner towards each arm; each
    LEAP hand takes the corner on its side and together they lift the towel until it hangs free of the table.

    **Randomisation:** the towel (`cloth.towel(8, 8)`: 2.5 cm particle spacing, particles of 1 cm radius,
    17.5 cm between corner centres, 24.7 cm across the diagonal) lies flat, its centre at x uniform in
    [-0.14, -0.06], y uniform in [-0.03, 0.03], its edges turned by a yaw uniform in
    [pi/4 - pi/36, pi/4 + pi/12] (the diagonal between the two hands' corners 85-105 degrees from the x axis).

    **Success:** every towel particle is at least `clearance` above the table (its lowest point, centre
    minus radius), and each hand holds the corner particle on its side (`left_grasped`, `right_grasped`:
    `ee.holds`, the "scissor" pinch the solver uses or a finger against the thumb or palm).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.28, 0.08, -0.2, 0.2)  # towel centres plus the towel's half diagonal
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("clearance",)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.towel = cloth.build_cloth(self.scene, "towel", cloth.towel(ROWS, COLS, self.cloth_config.spacing),
                                       self.cloth_config)
        self.hand_corners = side_corners(self.towel.layout)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            lay_between_hands(self.towel, len(env_idx))

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        obs.update(left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            points = self.towel.positions()
            obs["towel_points"] = points.flatten(1)
            for side, i in self.hand_corners.items():
                obs[f"{side}_tcp_to_corner"] = points[:, i] - self.ee.tcp(side).p
        return obs

    def evaluate(self):
        lowest = self.towel.positions()[..., 2].amin(dim=1) - self.cloth_config.radius
        grasped = {side: self.ee.holds(self.towel.spheres[i], side) for side, i in self.hand_corners.items()}
        return {
            "success": (lowest >= self.clearance) & grasped["left"] & grasped["right"],
            "lowest": lowest,
            "left_grasped": grasped["left"],
            "right_grasped": grasped["right"],
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        points = self.towel.positions()
        reward = sum(1 - torch.tanh(5 * torch.linalg.norm(points[:, i] - self.ee.tcp(side).p, dim=1))
                     for side, i in self.hand_corners.items())
        both = info["left_grasped"] & info["right_grasped"]
        reward += info["left_grasped"].float() + info["right_grasped"].float()
        reward += 2 * both * (info["lowest"] / self.clearance).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward


HOLD_HEIGHT = 0.28  # the pinched corners end this high: the 17.5 cm towel hanging below them clears the table
LIFT_STEP = 0.006  # metres a control step


def pinch_side_corners(s: DrivenSolver, towel: cloth.Cloth, hand_corners: dict[str, int]) -> dict[str, Grasp]:
    """Each LEAP hand scissor-pinches the corner particle `hand_corners[side]` of the flat `towel` (as
    DragTowelHand's corner pinch: fingers along the sheet's diagonal): both line up, move in and close
    together. Returns each side's Grasp (its TCP pose at the pinch)."""
    points = towel.positions()
    centroid = points.mean(dim=1)
    above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=points.device)
    grasps = {}
    for side, i in hand_corners.items():
        p, q = DrivenSolver.corner_scissor_pose(points[:, i], centroid, towel.config.radius,
                                                mirror=side == "left", around=ARM_YAW[side])
        grasps[side] = Grasp(f"{side}_arm", f"{side}_hand", p, q, above)
    for g in grasps.values():
        s.set_ee(g.ee, "scissor_open", steps=0)
    reach(s, list(grasps.values()), preshape=None)
    grasp_together(s, [g.ee for g in grasps.values()], "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
    return grasps


@register_solver("LiftTowelHands", control_modes=TCP_DELTA_MODES)
def solve_lift_towel_hands(env, seed: int) -> dict:
    """Each hand scissor-pinches the corner on its side (as DragTowelHand's corner pinch), both close together,
    then both rise together to `HOLD_HEIGHT`."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftTowelHandsEnv = env.unwrapped
        grasps = pinch_side_corners(s, task.towel, task.hand_corners).values()
        up = torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=task.device)
        glide(s, {g.arm: (g.p, g.p * torch.tensor([1.0, 1.0, 0.0], device=task.device) + up, g.q) for g in grasps},
              step_length=LIFT_STEP)
        s.hold_until_success()
        return s.info
