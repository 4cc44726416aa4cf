"""InsertPegBimanual (L2 rigid DG, family InsertPeg): the left arm holds a block with a hole up in the air by
its handle, the right arm inserts a square peg into it."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import top_down_quat
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver

from .base import InsertPegTask, insert_held_peg


@register_task("InsertPegBimanual")
class InsertPegBimanualEnv(InsertPegTask):
    """**Task:** the left arm picks up a block by its handle and holds it up in the air; the right arm picks
    up a square peg standing on the table and inserts it, upright, into the block's blind square hole, then
    lets go of it; the left arm keeps holding the block.

    Level 2 against Level 1 (HandoverCube: a cube passed between open grippers, put down in a 10 cm zone):
    the peg's lower end must enter a 32 mm opening with 1 mm of play on each side and the peg's yaw must
    match the hole's within about 4 degrees (square in square), 3 cm deep, into a block that hangs from
    the other gripper (it sways and tilts in that grasp, so the insertion follows it); four stages (two
    grasps, lift, insert) with both arms.

    **Randomisation:**
    - the block (1 cm walls around a hole of side 2 x `peg_half` + `clearance`, `hole_depth` deep over a
      1 cm floor, and a 12 cm handle as tall as the walls on one side; about 0.24 kg) lies on the left
      half of the table, its handle pointing left (+y) within [-15, 15] degrees, the hole's centre uniform
      in x in [-0.12, -0.02], y in [0.02, 0.08];
    - the peg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright on the right
      half with a uniform random yaw, its centre uniform in x in [-0.15, -0.03], y in [-0.25, -0.13].

    **Success:** (the InsertPeg family rule, `InsertPegTask`) the centre of the peg's lower end, in the
    block's frame, lies at least `insert_depth` below the hole's rim and inside the hole's square opening
    (half side `peg_half` plus half the `clearance`); the peg's axis is within `max_tilt` of the hole's;
    neither gripper holds the peg (`ee.holds`); and the left gripper holds the block (`ee.holds`) with
    the block's origin (the centre of its bottom face under the hole) at least `lift_height` above the table.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    PARAMS = InsertPegTask.PARAMS + ("lift_height",)
    max_dense_reward = 9
    TASK_REGION = (-0.25, 0.1, -0.35, 0.35)
    BLOCK_FIXED = False
    BLOCK_HANDLE = 0.12
    HANDLE_GRIP = 0.02  # the left gripper holds the handle this far from its free end (clear of the peg's hand)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            block_xyz = torch.stack([torch.rand(b) * 0.1 - 0.12, 0.02 + torch.rand(b) * 0.06, torch.zeros(b)], dim=1)
            yaw = np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(15)
            self.block.set_pose(Pose.create_from_pq(block_xyz, yaw_quat(yaw)))
            peg_xyz = torch.stack([torch.rand(b) * 0.12 - 0.15, -0.25 + torch.rand(b) * 0.12,
                                   torch.full((b,), self.peg_length / 2)], dim=1)
            self.peg.set_pose(Pose.create_from_pq(peg_xyz, yaw_quat(torch.rand(b) * np.pi / 2)))

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



BLOCK_LIFT = 0.1  # metres the left gripper raises the block
# of the two top-down hand yaws of a grasp, each arm takes the one nearest these: the left's wrist camera (on
# the hand's +x side) points away from the hole, and joint 7 stays clear of its limits all the way (the
# right's other choice ran it into +2.9 rad as it carried the peg to the left). The right's camera then faces
# the left hand: the 12 cm handle keeps the hands ~12.6 cm apart (at 8 cm they jammed in 6 of 6 seeds)
RIGHT_YAW = np.pi / 2
LEFT_YAW = np.pi / 2
PEG_LIFT = 0.2  # ... and the right one the peg: its lower end clears the raised block


@register_solver("InsertPegBimanual", control_modes=TCP_DELTA_MODES)
def solve_insert_peg_bimanual(env, seed: int) -> dict:
    """Both arms reach at once: the left to the handle (top-down, fingers across it), the right to the
    peg's upper end (top-down, fingers across the two faces that will face the handle's sides); both close
    and rise together, the block by `BLOCK_LIFT`, the peg by `PEG_LIFT`; the left holds still while the
    right carries the peg over the hole, lines it up, goes down, opens and backs off (`insert_held_peg`,
    closed loop on the measured peg and block)."""
    with DrivenSolver.episode(env, seed) as s:
        task: InsertPegBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        block_yaw = yaw_of(task.block.pose.q)
        left_q = top_down_quat(DrivenSolver.neutral_yaw(block_yaw - LEFT_YAW, np.pi) + LEFT_YAW, n, device)
        # the right fingers close along the block's y (across the handle): its hand lies clear of the left's
        peg_yaw = yaw_of(task.peg.pose.q)
        face = block_yaw + torch.remainder(peg_yaw - block_yaw + np.pi / 4, np.pi / 2) - np.pi / 4
        right_q = top_down_quat(DrivenSolver.neutral_yaw(face - RIGHT_YAW, np.pi) + RIGHT_YAW, n, device)
        peg_grasp = task.peg.pose.p.clone()
        peg_grasp[:, 2] += task.peg_length / 2 - 0.025
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        grasps = [Grasp("left_arm", "left_gripper", task.handle_point(), left_q, above),
                  Grasp("right_arm", "right_gripper", peg_grasp, right_q, above)]
        reach(s, grasps)
        grasp_together(s, ["left_gripper", "right_gripper"])
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        glide(s, {"left_arm": (grasps[0].p, grasps[0].p + BLOCK_LIFT * up, left_q),
                  "right_arm": (grasps[1].p, grasps[1].p + PEG_LIFT * up, right_q)}, step_length=0.015, settle_steps=5)
        insert_held_peg(s, task, "right_arm", "right_gripper", "right")
        s.hold_until_success()
        return s.info
