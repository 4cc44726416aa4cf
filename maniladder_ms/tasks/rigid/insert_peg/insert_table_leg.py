"""InsertTableLeg (L3 rigid DG, family InsertPeg): one arm holds a small table top up, the other inserts a leg into
its socket."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.objects.peg_hole import HoleBlockShape, build_hole_block, build_square_peg

from .base import HeldBlockInsertTask


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
class InsertTableLegEnv(HeldBlockInsertTask):
    """**Task:** a small table top lies upside down on the table, a square socket standing on its underside
    near one end and a grip bar along its middle; a square table leg stands upright beside it. The left arm
    picks the top up by its grip bar and holds it in the air; the right arm picks up the leg, inserts it,
    upright, into the socket while the top hangs from the left gripper, and lets go of it.

    **Randomisation:**
    - the table top (a 20 x 14 x 2 cm wooden plate, `TOP_PLATE`, reaching 4 cm behind the socket's axis; on it a
      socket of 1 cm walls around a square hole of side 2 x `peg_half` + `clearance`, `hole_depth` deep, and a
      12 cm grip bar, `BLOCK_HANDLE`, running from the socket along the plate's length; about 0.56 kg) lies with
      its grip bar pointing left (+y) within +-`block_max_yaw` (uniform), the socket's axis uniform in x in
      `block_x_range`, y in `block_y_range`;
    - the leg (a box of square section 2 x `peg_half`, `peg_length` long) stands upright on the right half,
      its yaw uniform in `peg_yaw_range`, its centre uniform in x in `peg_x_range`, y in `peg_y_range`.

    **Success:** (the InsertPeg family rule, `InsertPegTask`, with the two-arm rows' conditions,
    `HeldBlockInsertTask`) the centre of the leg's lower end, in the top's frame, lies at least `insert_depth`
    below the socket's rim and inside its square opening (half side `peg_half` plus half the `clearance`); the
    leg's axis is within `max_tilt` of the socket's; neither gripper holds the leg (`ee.holds`: it stays in the
    socket on its own); the left gripper holds the top (`ee.holds`) with the top's origin (the plate's bottom
    face under the socket) at least `lift_height` above the table; and, this task's conditions: the leg's
    lowest corner is at least `lift_height` above the table (it hangs in the held top, it does not stand on
    the table); and at no control step was the leg's lower end inside the socket's opening, below the rim,
    while the top was not held up that way (episode memory `loose_insertion`: a leg put in while the top lay
    on the table, or was let go of, fails for good).

    **Level 3:** (against Level 2's InsertPegBimanual, a 3 cm peg into a block held up by a 12 cm handle, 2 mm
    clearance: 1 mm of play a side, the peg's yaw within about 4 degrees of the hole's) the leg's 24 mm section
    goes into a socket with `clearance` 1 mm (0.5 mm of play a side), so its yaw must match the socket's within
    about 2.4 degrees and its lower end must be lined up to half a millimetre; the socket is not in a small
    block but near the end of a 20 cm plate of about 2.3 times the block's mass (0.56 kg against 0.24 kg)
    held by a grip bar 12 cm from the socket, the top's centre of mass 6 cm from the grip (the grasp must hold
    that torque, and the insertion follows the socket's measured pose); the top must be held up the whole time the leg is in the
    socket (checked at every control step, not only at the end); five stages (grasp the top, lift it, grasp the
    leg, carry it and line it up with the socket, insert and let go).
    """

    TOP_PLATE = (0.2, 0.14, 0.02)  # the plate: length (along the grip bar), width, thickness
    TOP_PLATE_BACK = 0.04  # the plate reaches this far behind the socket's axis
    HANDLE_GRIP_BELOW = 0.015  # the grip point this far below the grip bar's top (the fingertips clear the plate)

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

    def leg_bottom_height(self) -> torch.Tensor:
        """(b,) height above the table of the leg's lowest corner."""
        rows = self._rotation(self.peg)[:, 2, :].abs()
        half = torch.tensor([self.peg_half, self.peg_half, self.peg_length / 2], device=self.device)
        return self.peg.pose.p[:, 2] - (rows * half).sum(dim=1)

    def block_reach(self) -> float:
        length, width, _ = self.TOP_PLATE
        far = max(length - self.TOP_PLATE_BACK, self.TOP_PLATE_BACK)
        return float(np.linalg.norm([far, width / 2, self.hole.rim_height])) + self.HOLD_REACH_MARGIN

    def _update_memory(self):
        state = self.insertion_state()
        inside = (state["depth"] > 0) & state["in_opening"] & ~self.memory["loose_insertion"]
        if bool(inside.any()):
            up = self.block_held_up()
            self.memory.latch("loose_insertion", inside & ~(up["block_grasped"] & up["block_lifted"]))

    def task_conditions(self, info: dict) -> torch.Tensor:
        held_up = super().task_conditions(info)
        info["leg_off_table"] = self.leg_bottom_height() >= self.lift_height
        info["loose_insertion"] = self.memory["loose_insertion"]
        return held_up & info["leg_off_table"] & ~info["loose_insertion"]

    def _get_obs_extra(self, info: dict):
        obs = super()._get_obs_extra(info)
        if "state" in self.obs_mode:
            obs.update(loose_insertion=info["loose_insertion"])
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # the two-arm rows' reward (reach and hold, lift, line up, insert, let go), nothing once the leg was in
        # the socket while the top was not held up
        reward = super().compute_dense_reward(obs, action, info) * (~info["loose_insertion"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
