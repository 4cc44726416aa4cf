"""InsertPegBimanual (L2 rigid DG, family InsertPeg): a peg inserted into a block the other arm holds up."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from .base import InsertPegTask


@register_task("InsertPegBimanual")
class InsertPegBimanualEnv(InsertPegTask):
    """**Task:** the left arm picks up a block by its handle and holds it up in the air; the right arm picks
    up a square peg standing on the table and inserts it, upright, into the block's blind square hole, then
    lets go of it; the left arm keeps holding the block.

    **Randomisation:**
    - the block (1 cm walls around a hole of side 2 x `peg_half` + `clearance`, `hole_depth` deep over a
      1 cm floor, and a 12 cm handle as tall as the walls on one side; about 0.24 kg) lies on the left
      half of the table, its handle pointing left (+y) within +-`block_max_yaw` (uniform), the hole's centre
      uniform in x in `block_x_range`, y in `block_y_range`;
    - the peg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright on the right
      half, its yaw uniform in `peg_yaw_range`, its centre uniform in x in `peg_x_range`, y in `peg_y_range`.

    **Success:** (the InsertPeg family rule, `InsertPegTask`) the centre of the peg's lower end, in the
    block's frame, lies at least `insert_depth` below the hole's rim and inside the hole's square opening
    (half side `peg_half` plus half the `clearance`); the peg's axis is within `max_tilt` of the hole's;
    neither gripper holds the peg (`ee.holds`); and the left gripper holds the block (`ee.holds`) with
    the block's origin (the centre of its bottom face under the hole) at least `lift_height` above the table.

    **Level 2:** (against Level 1's HandoverCube: a cube passed between open grippers, put down in a 10 cm
    zone) the peg's lower end must enter a 32 mm opening with 1 mm of play on each side and the peg's yaw
    must match the hole's within about 4 degrees (square in square), 3 cm deep, into a block that hangs from
    the other gripper (it sways and tilts in that grasp, so the insertion follows it); four stages (two
    grasps, lift, insert) with both arms.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    PARAMS = InsertPegTask.PARAMS + ("lift_height", "block_x_range", "block_y_range", "block_max_yaw", "peg_x_range",
                                     "peg_y_range", "peg_yaw_range")
    max_dense_reward = 9
    TASK_REGION = (-0.25, 0.1, -0.35, 0.35)
    BLOCK_FIXED = False
    BLOCK_HANDLE = 0.12
    HANDLE_GRIP = 0.02  # the left gripper holds the handle this far from its free end (clear of the peg's hand)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            block_xyz = torch.stack([uniform(b, self.block_x_range), uniform(b, self.block_y_range), torch.zeros(b)],
                                    dim=1)
            yaw = np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.block_max_yaw)
            self.block.set_pose(Pose.create_from_pq(block_xyz, yaw_quat(yaw)))
            peg_xyz = torch.stack([uniform(b, self.peg_x_range), uniform(b, self.peg_y_range),
                                   torch.full((b,), self.peg_length / 2)], dim=1)
            self.peg.set_pose(Pose.create_from_pq(peg_xyz, yaw_quat(uniform_deg(b, self.peg_yaw_range))))

    def handle_point(self) -> torch.Tensor:
        """(b, 3) world position where the left gripper holds the handle: `HANDLE_GRIP` from its free end,
        2 cm below its top."""
        x = self.hole.outer_half + self.BLOCK_HANDLE - self.HANDLE_GRIP
        return self.block_point([x, 0.0, self.hole.rim_height - 0.02])

    def task_conditions(self, info: dict) -> torch.Tensor:
        # the contact query only where the left TCP is within reach of the block (its farthest corner from
        # its origin plus the margin of `holds_peg`)
        h = self.hole
        reach = float(np.linalg.norm([h.outer_half + h.handle, h.outer_half, h.rim_height])) + self.HOLD_REACH_MARGIN
        near = torch.linalg.norm(self.ee.tcp("left").p - self.block.pose.p, dim=1) <= reach
        info["block_grasped"] = (self.ee.holds(self.block, "left") & near) if bool(near.any()) else near
        info["block_lifted"] = self.block.pose.p[:, 2] >= self.lift_height
        return info["block_grasped"] & info["block_lifted"]

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   block_grasped=info["block_grasped"], peg_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(peg_pose=self.peg.pose.raw_pose, block_pose=self.block.pose.raw_pose,
                       left_tcp_to_handle=self.handle_point() - self.ee.tcp("left").p,
                       right_tcp_to_peg=self.peg.pose.p - self.ee.tcp("right").p,
                       peg_tip_to_mouth=self.hole_mouth() - self.peg_tip())
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        left_reach = torch.linalg.norm(self.handle_point() - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(self.peg.pose.p - self.ee.tcp("right").p, dim=1)
        block_held, peg_held = info["block_grasped"], info["right_peg_grasped"]
        reward = (1 - torch.tanh(5 * left_reach)) + block_held.float()
        reward += (self.block.pose.p[:, 2] / self.lift_height).clamp(0, 1) * block_held
        reward += (1 - torch.tanh(5 * right_reach)) + peg_held.float()
        # the insertion counts while the block is held up
        ready = block_held & info["block_lifted"] & (peg_held | info["is_inserted"])
        reward += self.insertion_reward(info) * ready
        reward += (info["is_inserted"] & ~info["is_grasped"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
