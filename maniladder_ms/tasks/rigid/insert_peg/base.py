"""The InsertPeg family's base (InsertPegInHole, InsertPegBimanual, InsertTableLeg; later InsertPegTight): a square
peg goes into a blind square hole in a block, and stays there on its own.

The family base `InsertPegTask` builds the peg and the hole block from the catalog params (the same builders,
`objects.peg_hole`, for every row: a row's `clearance` sets the hole's width) and holds the rule, `evaluate`,
once; the task classes place the objects, say whether the block is a fixture or a free body with a handle and
add their own conditions (`task_conditions`); the two-arm rows (InsertPegBimanual, InsertTableLeg), where the left
arm holds the block up by its handle, share `HeldBlockInsertTask`. Their solvers, and the insertion phase they share
(`solvers/rigid/insert_peg/phases.py`), are in `maniladder_ms/solvers/rigid/insert_peg/`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.peg_hole import HoleBlockShape, build_hole_block, build_square_peg


class InsertPegTask(ManiLadderEnv):
    """Family base (registers no task). **Success:** the peg is inserted: its lower end's centre, in the
    block's frame (z along the hole's axis), lies at least `insert_depth` below the hole's rim and inside
    the hole's square opening (half side `peg_half` plus half the `clearance`); the peg's axis is within
    `max_tilt` of the hole's; no gripper holds the peg (`ee.holds`: it stays in the hole on its own); and
    the task's own conditions hold (`task_conditions`).
    """

    PARAMS = ("peg_half", "peg_length", "clearance", "hole_depth", "insert_depth", "max_tilt")
    # the block: a fixture (kinematic) or a free body; the length of its handle along its +x (0: none)
    BLOCK_FIXED = True
    BLOCK_HANDLE = 0.0
    BLOCK_WALL = 0.01
    BLOCK_BASE = 0.01

    @property
    def hole(self) -> HoleBlockShape:
        return HoleBlockShape(hole_half=self.peg_half + self.clearance / 2, depth=self.hole_depth,
                              wall=self.BLOCK_WALL, base=self.BLOCK_BASE, handle=self.BLOCK_HANDLE)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.peg = build_square_peg(self.scene, "peg", self.peg_half, self.peg_length, color=(0.85, 0.65, 0.3, 1),
                                    tip_color=(0.8, 0.15, 0.1, 1))
        self.block = build_hole_block(self.scene, "hole_block", self.hole, color=(0.3, 0.45, 0.7, 1),
                                      rim_color=(0.95, 0.95, 0.95, 1), kinematic=self.BLOCK_FIXED)

    # a gripper whose TCP is further than this from the peg's centre cannot hold it (the peg's far corner
    # lies `peg_length` / 2 + 0.5 cm from its centre, the finger pads within 3 cm of the TCP): `holds_peg`
    # skips its contact query there (a contact query is the costliest part of a CPU step)
    HOLD_REACH_MARGIN = 0.05

    @staticmethod
    def _rotation(actor) -> torch.Tensor:
        """(b, 3, 3) rotation of an actor (a closed form: ManiSkill's quaternion_to_matrix took a fifth of a step)."""
        w, x, y, z = actor.pose.q.unbind(-1)
        return torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                            2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                            2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], dim=-1).reshape(-1, 3, 3)

    def block_point(self, local: torch.Tensor) -> torch.Tensor:
        """(b, 3) world position of the point `local` (3,) of the block's frame."""
        return self.block.pose.p + self._rotation(self.block) @ torch.as_tensor(local, dtype=torch.float32, device=self.device)

    def peg_tip(self) -> torch.Tensor:
        """(b, 3) world position of the centre of the peg's lower end."""
        return self.peg.pose.p - self.peg_length / 2 * self._rotation(self.peg)[:, :, 2]

    def hole_mouth(self) -> torch.Tensor:
        """(b, 3) world position of the centre of the hole's opening (on the rim's plane)."""
        return self.block_point([0.0, 0.0, self.hole.rim_height])

    def insertion_state(self) -> dict[str, torch.Tensor]:
        """The rule's measurements: `depth` (m below the rim of the peg's lower end, in the block's frame),
        `lateral` (m, the larger of its |x|, |y| offsets from the hole's axis; `offset` their norm), `tilt` (rad
        between the axes)."""
        block_r = self._rotation(self.block)
        local = ((self.peg_tip() - self.block.pose.p).unsqueeze(1) @ block_r).squeeze(1)
        depth = self.hole.rim_height - local[:, 2]
        lateral = local[:, :2].abs().max(dim=1).values
        cos = (self._rotation(self.peg)[:, :, 2] * block_r[:, :, 2]).sum(dim=1).clamp(-1, 1)
        tilt = torch.arccos(cos)
        is_aligned = tilt <= np.deg2rad(self.max_tilt)
        in_opening = lateral <= self.hole.hole_half
        return dict(depth=depth, lateral=lateral, offset=local[:, :2].norm(dim=1), tilt=tilt, is_aligned=is_aligned,
                    in_opening=in_opening, is_inserted=(depth >= self.insert_depth) & in_opening & is_aligned)

    def holds_peg(self, side: str) -> torch.Tensor:
        """(b,) bool: `ee.holds(peg, side)`, asked only where that TCP is within reach of the peg."""
        near = torch.linalg.norm(self.ee.tcp(side).p - self.peg.pose.p, dim=1) <= self.peg_length / 2 + self.HOLD_REACH_MARGIN
        if not bool(near.any()):
            return near
        return self.ee.holds(self.peg, side) & near

    def task_conditions(self, info: dict) -> torch.Tensor:
        """(b,) bool: what the task adds to the family rule (all True by default); may add flags to `info`."""
        return torch.ones(self.num_envs, dtype=torch.bool, device=self.device)

    def evaluate(self):
        info = self.insertion_state()
        held = {side: self.holds_peg(side) for side in self.ee.sides}
        info["is_grasped"] = torch.stack(list(held.values())).any(dim=0)
        if len(held) > 1:
            info.update({f"{side}_peg_grasped": flag for side, flag in held.items()})
        info["success"] = info["is_inserted"] & ~info["is_grasped"] & self.task_conditions(info)
        return info

    def insertion_reward(self, info: dict) -> torch.Tensor:
        """(b,) in [0, 3]: the peg's tip over the hole's mouth and aligned (up to 2), then as deep as
        `insert_depth` (up to 1): the stages every task's dense reward ends with."""
        to_mouth = info["offset"] + (-info["depth"]).clamp(min=0)
        align = (1 - torch.tanh(10 * to_mouth)) + (1 - info["tilt"] / np.pi)
        deep = (info["depth"] / self.insert_depth).clamp(0, 1) * (info["in_opening"] & info["is_aligned"])
        return align + deep


class HeldBlockInsertTask(InsertPegTask):
    """The two-arm rows' base (registers no task): the block, a free body with a handle, lies on the left half of
    the table, its handle pointing left (+y) within +-`block_max_yaw`, the hole's axis uniform in x in
    `block_x_range`, y in `block_y_range`; the peg stands upright on the right half, its yaw uniform in
    `peg_yaw_range`, its centre in `peg_x_range`, `peg_y_range`. The task's conditions: the left gripper holds the
    block (`ee.holds`) with the block's origin at least `lift_height` above the table (`block_grasped`,
    `block_lifted`)."""

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    PARAMS = InsertPegTask.PARAMS + ("lift_height", "block_x_range", "block_y_range", "block_max_yaw", "peg_x_range",
                                     "peg_y_range", "peg_yaw_range")
    max_dense_reward = 9
    TASK_REGION = (-0.25, 0.1, -0.35, 0.35)
    BLOCK_FIXED = False
    BLOCK_HANDLE = 0.12
    HANDLE_GRIP = 0.02  # the left gripper holds the handle this far from its free end (clear of the peg's hand)
    HANDLE_GRIP_BELOW = 0.02  # ... and this far below its top

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
        `HANDLE_GRIP_BELOW` below its top."""
        x = self.hole.outer_half + self.BLOCK_HANDLE - self.HANDLE_GRIP
        return self.block_point([x, 0.0, self.hole.rim_height - self.HANDLE_GRIP_BELOW])

    def block_reach(self) -> float:
        """How far from the block's origin a TCP can be and still hold it: its farthest corner plus the margin
        of `holds_peg` (beyond it `block_held_up` skips the contact query)."""
        h = self.hole
        return float(np.linalg.norm([h.outer_half + h.handle, h.outer_half, h.rim_height])) + self.HOLD_REACH_MARGIN

    def block_held_up(self) -> dict[str, torch.Tensor]:
        """`block_grasped` (the left gripper holds the block) and `block_lifted` (its origin at least
        `lift_height` above the table)."""
        near = torch.linalg.norm(self.ee.tcp("left").p - self.block.pose.p, dim=1) <= self.block_reach()
        grasped = (self.ee.holds(self.block, "left") & near) if bool(near.any()) else near
        return dict(block_grasped=grasped, block_lifted=self.block.pose.p[:, 2] >= self.lift_height)

    def task_conditions(self, info: dict) -> torch.Tensor:
        info.update(self.block_held_up())
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
