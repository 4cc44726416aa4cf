"""InsertPegInHole (L2 rigid SG, family InsertPeg): insert a square peg into the blind hole of a fixed block."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from .base import InsertPegTask


@register_task("InsertPegInHole")
class InsertPegInHoleEnv(InsertPegTask):
    """**Task:** pick up a square peg standing upright on the table and insert it, upright, into the
    square blind hole of a block fixed to the table; let go of it there.

    **Randomisation:**
    - the peg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright with a uniform
      random yaw, its centre uniform in x in [-0.12, 0.05], |y| in [0.08, 0.2] (`PEG_X`, `PEG_Y`) on a random
      side of the robot's centre line;
    - the block (a fixture: 1 cm walls around a hole of side 2 x `peg_half` + `clearance`, `hole_depth`
      deep over a 1 cm floor) stands on the other side, centre x in [-0.1, 0.08], |y| in [0.08, 0.2]
      (`BLOCK_X`, `BLOCK_Y`), yaw uniform in [-pi/4, pi/4].

    **Success:** (the InsertPeg family rule, `InsertPegTask`) the centre of the peg's lower end, in the
    block's frame, lies at least `insert_depth` below the hole's rim and inside the hole's square opening
    (half side `peg_half` plus half the `clearance`); the peg's axis is within `max_tilt` of the hole's;
    and the gripper does not hold the peg (`ee.holds`).

    **Level 2:** (against Level 1's PickPlacePen: anywhere in a tray 22 x 11 cm with a 2 cm margin) the peg's
    lower end must enter a 32 mm opening with 1 mm of play on each side and the peg's yaw must match the
    hole's within about 4 degrees (square in square), before it goes 4 cm down; three stages (grasp,
    align over the hole, insert) with a mm-level tolerance.
    """

    max_dense_reward = 7
    TASK_REGION = (-0.2, 0.15, -0.3, 0.3)
    # layout ranges as (low, span); y is the distance from the robot's centre line, on opposite sides
    PEG_X, PEG_Y = (-0.12, 0.17), (0.08, 0.12)
    BLOCK_X, BLOCK_Y = (-0.1, 0.18), (0.08, 0.12)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            side = torch.where(torch.rand(b) < 0.5, -1.0, 1.0)
            peg_xyz = torch.stack([torch.rand(b) * self.PEG_X[1] + self.PEG_X[0],
                                   side * (self.PEG_Y[0] + torch.rand(b) * self.PEG_Y[1]),
                                   torch.full((b,), self.peg_length / 2)], dim=1)
            self.peg.set_pose(Pose.create_from_pq(peg_xyz, yaw_quat(torch.rand(b) * np.pi / 2)))
            block_xyz = torch.stack([torch.rand(b) * self.BLOCK_X[1] + self.BLOCK_X[0],
                                     -side * (self.BLOCK_Y[0] + torch.rand(b) * self.BLOCK_Y[1]),
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
