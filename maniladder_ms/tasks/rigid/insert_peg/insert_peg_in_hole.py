"""InsertPegInHole (L2 rigid SG, family InsertPeg): insert a square peg into the blind hole of a fixed block."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform, uniform_deg
from .base import InsertPegTask


@register_task("InsertPegInHole")
class InsertPegInHoleEnv(InsertPegTask):
    """**Task:** pick up a square peg standing upright on the table and insert it, upright, into the
    square blind hole of a block fixed to the table; let go of it there.

    **Randomisation:**
    - the peg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright, its yaw uniform in
      `peg_yaw_range` (a square section: every yaw), its centre uniform in x in `peg_x_range`, y in
      `peg_y_range` (9 x 6 cm, left of the robot's centre line);
    - the block (a fixture: 1 cm walls around a hole of side 2 x `peg_half` + `clearance`, `hole_depth`
      deep over a 1 cm floor) stands on the right, centre x in `block_x_range`, y in `block_y_range`
      (10 x 6 cm), yaw uniform in +-`block_max_yaw`. One side each: which side is not the task (layout
      policy rule 1, docs/calibration/layout-policy.md).

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
    PARAMS = InsertPegTask.PARAMS + ("peg_x_range", "peg_y_range", "peg_yaw_range", "block_x_range",
                                     "block_y_range", "block_max_yaw")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            peg_xyz = torch.stack([uniform(b, self.peg_x_range), uniform(b, self.peg_y_range),
                                   torch.full((b,), self.peg_length / 2)], dim=1)
            self.peg.set_pose(Pose.create_from_pq(peg_xyz, yaw_quat(uniform_deg(b, self.peg_yaw_range))))
            block_xyz = torch.stack([uniform(b, self.block_x_range), uniform(b, self.block_y_range),
                                     torch.zeros(b)], dim=1)
            self.block.set_pose(Pose.create_from_pq(block_xyz, yaw_quat(symmetric_deg(b, self.block_max_yaw))))

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
