"""InsertTableLeg (L3 rigid DG, family InsertPeg): one arm holds a small table top up, the other inserts a leg into
its socket."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.peg_hole import HoleBlockShape, build_hole_block, build_square_peg

from .base import InsertPegTask


@dataclass(frozen=True)
class TableTopShape(HoleBlockShape):
    """A table top lying upside down: a plate `plate` (length along +x, width, thickness) reaching `plate_back`
    behind the socket's axis, the socket (the hole block's four walls, `depth` deep, on the plate) and a grip
    bar (the hole block's `handle`) along +x on the plate. The frame's origin lies on the socket's axis at the
    plate's bottom face (`base` = the plate's thickness)."""

    plate: tuple[float, float, float] = (0.2, 0.14, 0.02)
    plate_back: float = 0.04

    def parts(self) -> list[tuple[list[float], list[float]]]:
        length, width, thick = self.plate
        plate = ([length / 2 - self.plate_back, 0, thick / 2], [length / 2, width / 2, thick / 2])
        return [plate] + super().parts()[1:]


@register_task("InsertTableLeg")
class InsertTableLegEnv(InsertPegTask):
    """**Task:** a small table top lies upside down on the table, a square socket standing on its underside
    near one end and a grip bar along its middle; a square table leg stands upright beside it. The left arm
    picks the top up by its grip bar and holds it in the air; the right arm picks up the leg, inserts it,
    upright, into the socket while the top hangs from the left gripper, and lets go of it.

    **Randomisation:**
    - the table top (a 20 x 14 x 2 cm wooden plate, `TOP_PLATE`, reaching 4 cm behind the socket's axis; on it a
      socket of 1 cm walls around a square hole of side 2 x `peg_half` + `clearance`, `hole_depth` deep, and a
      12 cm grip bar, `BLOCK_HANDLE`, running from the socket along the plate's length; about 0.57 kg) lies with
      its grip bar pointing left (+y) within [-15, 15] degrees (`BLOCK_YAW`), the socket's axis uniform in x in
      [-0.12, -0.02], y in [0.02, 0.08] (`BLOCK_X`, `BLOCK_Y`);
    - the leg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright on the right half
      with a uniform random yaw, its centre uniform in x in [-0.15, -0.03], y in [-0.25, -0.13] (`PEG_X`,
      `PEG_Y`).

    **Success:** (the InsertPeg family rule, `InsertPegTask`) the centre of the leg's lower end, in the top's
    frame, lies at least `insert_depth` below the socket's rim and inside its square opening (half side
    `peg_half` plus half the `clearance`); the leg's axis is within `max_tilt` of the socket's; neither gripper
    holds the leg (`ee.holds`: it stays in the socket on its own); and, this task's conditions: the left
    gripper holds the top (`ee.holds`) with the top's origin (the plate's bottom face under the socket) at
    least `lift_height` above the table; the leg's lowest corner is at least `lift_height` above the table
    (it hangs in the held top, it does not stand on the table); and at no control step was the leg's lower
    end inside the socket's opening, below the rim, while the top was not held up that way (episode memory
    `loose_insertion`: a leg put in while the top lay on the table, or was let go of, fails for good).

    **Level 3:** (against Level 2's InsertPegBimanual, a 3 cm peg into a block held up by a 12 cm handle, 2 mm
    clearance: 1 mm of play a side, the peg's yaw within about 4 degrees of the hole's) the leg's 24 mm section
    goes into a socket with `clearance` 1 mm (0.5 mm of play a side), so its yaw must match the socket's within
    about 2.4 degrees and its lower end must be lined up to half a millimetre; the socket is not in a small
    block but at the end of a 20 cm plate of about 2.4 times the block's mass (0.57 kg against 0.24 kg) whose
    centre of mass lies 6 cm from the grip, 12 cm from the socket (the grasp must hold that torque, and the
    insertion follows the socket's measured pose); the top must be held up the whole time the leg is in the
    socket (checked at every control step, not only at the end); five stages (grasp the top, lift it, grasp the
    leg, carry it and line it up with the socket, insert and let go).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    PARAMS = InsertPegTask.PARAMS + ("lift_height",)
    max_dense_reward = 9
    TASK_REGION = (-0.25, 0.1, -0.35, 0.35)
    BLOCK_FIXED = False
    BLOCK_HANDLE = 0.12
    TOP_PLATE = (0.2, 0.14, 0.02)  # the plate: length (along the grip bar), width, thickness
    TOP_PLATE_BACK = 0.04  # the plate reaches this far behind the socket's axis
    HANDLE_GRIP = 0.02  # the left gripper holds the grip bar this far from its free end
    HANDLE_GRIP_BELOW = 0.015  # ... and this far below its top (the fingertips stay clear of the plate)
    # layout ranges as (low, span)
    BLOCK_X, BLOCK_Y = (-0.12, 0.1), (0.02, 0.06)
    BLOCK_YAW = 15  # degrees either side of the grip bar pointing +y
    PEG_X, PEG_Y = (-0.15, 0.12), (-0.25, 0.12)

    @property
    def hole(self) -> TableTopShape:
        return TableTopShape(hole_half=self.peg_half + self.clearance / 2, depth=self.hole_depth,
                             wall=self.BLOCK_WALL, base=self.TOP_PLATE[2], handle=self.BLOCK_HANDLE,
                             plate=self.TOP_PLATE, plate_back=self.TOP_PLATE_BACK)

    def _load_scene(self, options: dict):
        ManiLadderEnv._load_scene(self, options)  # the family base's peg and hole block are built here instead
        self.peg = build_square_peg(self.scene, "leg", self.peg_half, self.peg_length, color=(0.88, 0.72, 0.45, 1),
                                    tip_color=(0.8, 0.15, 0.1, 1))
        self.block = build_hole_block(self.scene, "table_top", self.hole, color=(0.42, 0.27, 0.16, 1),
                                      rim_color=(0.95, 0.95, 0.95, 1), kinematic=False)
        self.memory.flag("loose_insertion")  # the leg in the socket while the top was not held up

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            top_xyz = torch.stack([torch.rand(b) * self.BLOCK_X[1] + self.BLOCK_X[0],
                                   self.BLOCK_Y[0] + torch.rand(b) * self.BLOCK_Y[1], torch.zeros(b)], dim=1)
            yaw = np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.BLOCK_YAW)
            self.block.set_pose(Pose.create_from_pq(top_xyz, yaw_quat(yaw)))
            leg_xyz = torch.stack([torch.rand(b) * self.PEG_X[1] + self.PEG_X[0],
                                   self.PEG_Y[0] + torch.rand(b) * self.PEG_Y[1],
                                   torch.full((b,), self.peg_length / 2)], dim=1)
            self.peg.set_pose(Pose.create_from_pq(leg_xyz, yaw_quat(torch.rand(b) * np.pi / 2)))

    def handle_point(self) -> torch.Tensor:
        """(b, 3) world position where the left gripper holds the grip bar: `HANDLE_GRIP` from its free end,
        `HANDLE_GRIP_BELOW` below its top."""
        x = self.hole.outer_half + self.BLOCK_HANDLE - self.HANDLE_GRIP
        return self.block_point([x, 0.0, self.hole.rim_height - self.HANDLE_GRIP_BELOW])

    def leg_bottom_height(self) -> torch.Tensor:
        """(b,) height above the table of the leg's lowest corner."""
        rows = self._rotation(self.peg)[:, 2, :].abs()
        half = torch.tensor([self.peg_half, self.peg_half, self.peg_length / 2], device=self.device)
        return self.peg.pose.p[:, 2] - (rows * half).sum(dim=1)

    def top_held_up(self) -> dict[str, torch.Tensor]:
        """`block_grasped` (the left gripper holds the top; the contact query only where its TCP is within
        reach of the top: the plate's farthest corner from the origin plus the family's margin) and
        `block_lifted` (the top's origin at least `lift_height` above the table)."""
        length, width, thick = self.TOP_PLATE
        far = max(length - self.TOP_PLATE_BACK, self.TOP_PLATE_BACK)
        reach = float(np.linalg.norm([far, width / 2, self.hole.rim_height])) + self.HOLD_REACH_MARGIN
        near = torch.linalg.norm(self.ee.tcp("left").p - self.block.pose.p, dim=1) <= reach
        grasped = (self.ee.holds(self.block, "left") & near) if bool(near.any()) else near
        return dict(block_grasped=grasped, block_lifted=self.block.pose.p[:, 2] >= self.lift_height)

    def _update_memory(self):
        state = self.insertion_state()
        inside = (state["depth"] > 0) & state["in_opening"] & ~self.memory["loose_insertion"]
        if bool(inside.any()):
            up = self.top_held_up()
            self.memory.latch("loose_insertion", inside & ~(up["block_grasped"] & up["block_lifted"]))

    def task_conditions(self, info: dict) -> torch.Tensor:
        info.update(self.top_held_up())
        info["leg_off_table"] = self.leg_bottom_height() >= self.lift_height
        info["loose_insertion"] = self.memory["loose_insertion"]
        return info["block_grasped"] & info["block_lifted"] & info["leg_off_table"] & ~info["loose_insertion"]

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   top_grasped=info["block_grasped"], leg_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(leg_pose=self.peg.pose.raw_pose, top_pose=self.block.pose.raw_pose,
                       left_tcp_to_grip=self.handle_point() - self.ee.tcp("left").p,
                       right_tcp_to_leg=self.peg.pose.p - self.ee.tcp("right").p,
                       leg_tip_to_socket=self.hole_mouth() - self.peg_tip(),
                       loose_insertion=info["loose_insertion"])
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        left_reach = torch.linalg.norm(self.handle_point() - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(self.peg.pose.p - self.ee.tcp("right").p, dim=1)
        top_held, leg_held = info["block_grasped"], info["right_peg_grasped"]
        reward = (1 - torch.tanh(5 * left_reach)) + top_held.float()
        reward += (self.block.pose.p[:, 2] / self.lift_height).clamp(0, 1) * top_held
        reward += (1 - torch.tanh(5 * right_reach)) + leg_held.float()
        # the insertion counts while the top is held up
        ready = top_held & info["block_lifted"] & (leg_held | info["is_inserted"])
        reward += self.insertion_reward(info) * ready
        reward += (info["is_inserted"] & ~info["is_grasped"]).float()
        reward *= (~info["loose_insertion"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
