"""InsertPegInHole (L2 rigid SG, family InsertPeg): pick a square peg standing on the table and insert it into
the blind square hole of a block fixed to the table."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver

from .base import InsertPegTask, insert_held_peg


@register_task("InsertPegInHole")
class InsertPegInHoleEnv(InsertPegTask):
    """**Task:** pick up a square peg standing upright on the table and insert it, upright, into the
    square blind hole of a block fixed to the table; let go of it there.

    Level 2 against Level 1 (PickPlacePen: anywhere in a tray 22 x 11 cm with a 2 cm margin): the peg's
    lower end must enter a 32 mm opening with 1 mm of play on each side and the peg's yaw must match the
    hole's within about 4 degrees (square in square), before it goes 4 cm down; three stages (grasp,
    align over the hole, insert) with a mm-level tolerance.

    **Randomisation:**
    - the peg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright with a uniform
      random yaw, its centre uniform in x in [-0.12, 0.05], |y| in [0.08, 0.2] on a random side of the
      robot's centre line;
    - the block (a fixture: 1 cm walls around a hole of side 2 x `peg_half` + `clearance`, `hole_depth`
      deep over a 1 cm floor) stands on the other side, centre x in [-0.1, 0.08], |y| in [0.08, 0.2], yaw
      uniform in [-pi/4, pi/4].

    **Success:** (the InsertPeg family rule, `InsertPegTask`) the centre of the peg's lower end, in the
    block's frame, lies at least `insert_depth` below the hole's rim and inside the hole's square opening
    (half side `peg_half` plus half the `clearance`); the peg's axis is within `max_tilt` of the hole's;
    and the gripper does not hold the peg (`ee.holds`).
    """

    max_dense_reward = 7
    TASK_REGION = (-0.2, 0.15, -0.3, 0.3)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            side = torch.where(torch.rand(b) < 0.5, -1.0, 1.0)
            peg_xyz = torch.stack([torch.rand(b) * 0.17 - 0.12, side * (0.08 + torch.rand(b) * 0.12),
                                   torch.full((b,), self.peg_length / 2)], dim=1)
            self.peg.set_pose(Pose.create_from_pq(peg_xyz, yaw_quat(torch.rand(b) * np.pi / 2)))
            block_xyz = torch.stack([torch.rand(b) * 0.18 - 0.1, -side * (0.08 + torch.rand(b) * 0.12),
                                     torch.zeros(b)], dim=1)
            self.block.set_pose(Pose.create_from_pq(block_xyz, yaw_quat((torch.rand(b) - 0.5) * np.pi / 2)))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(peg_pose=self.peg.pose.raw_pose, block_pose=self.block.pose.raw_pose,
                       tcp_to_peg_pos=self.peg.pose.p - self.ee.tcp().p,
                       peg_tip_to_mouth=self.hole_mouth() - self.peg_tip())
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        tcp_to_peg = torch.linalg.norm(self.peg.pose.p - self.ee.tcp().p, dim=1)
        reward = 1 - torch.tanh(5 * tcp_to_peg)
        is_grasped = info["is_grasped"]
        reward += is_grasped
        # while held or once in the hole: over the mouth, aligned, down to the depth
        reward += self.insertion_reward(info) * (is_grasped | info["is_inserted"])
        reward += (info["is_inserted"] & ~is_grasped).float()
        reward[info["success"]] = self.max_dense_reward
        return reward



GRASP_BELOW_TOP = 0.025  # the TCP this far below the peg's top face: the finger pads hold its upper end


@register_solver("InsertPegInHole", control_modes=TCP_DELTA_MODES)
def solve_insert_peg_in_hole(env, seed: int) -> dict:
    """Grasp the peg's upper end from above, fingers across two faces; lift; carry it upright over the hole,
    its faces turned along the hole's walls, line it up over the opening, go down, open, back off upwards
    (`insert_held_peg`, closed loop on the measured peg in the hand)."""
    with DrivenSolver.episode(env, seed) as s:
        task: InsertPegInHoleEnv = env.unwrapped
        yaw = DrivenSolver.neutral_yaw(yaw_of(task.peg.pose.q), np.pi / 2)
        grasp_p = task.peg.pose.p.clone()
        grasp_p[:, 2] += task.peg_length / 2 - GRASP_BELOW_TOP
        s.pick("arm", "gripper", grasp_p, yaw, lift=0.1)
        insert_held_peg(s, task, "arm", "gripper", None)
        s.hold_until_success()
        return s.info
