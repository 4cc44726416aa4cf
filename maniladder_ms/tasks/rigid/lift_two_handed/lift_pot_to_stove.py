"""LiftPotToStove (L2 rigid DG, family LiftTwoHanded): carry a pot by its two handles onto a stove plate."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import tilt, yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.pot import PotShape, build_pot, build_stove_plate

from .base import SIDE_SIGNS, LiftTwoHandedTask

POT_DENSITY = 1200.0  # kg/m^3: the pot weighs ~0.9 kg


@register_task("LiftPotToStove")
class LiftPotToStoveEnv(LiftTwoHandedTask):
    """**Task:** a pot with two side handles stands on the table; a round stove plate stands farther from the
    robot. Each arm takes one handle, both lift the pot together, carry it over the plate and set it down
    there, level, and let go.

    **Randomisation:** the pot (19 cm across, 9 cm high, ~0.9 kg; flat tab handles 5 cm long and 3 cm wide
    at +-y, 1.5 cm below the rim) stands with its centre uniform in x in `pot_x_range`, y in `pot_y_range` and
    its yaw uniform in +-`pot_max_yaw`; the stove plate (11 cm radius, 1.2 cm high) stands farther in x by a
    distance uniform in `plate_dx_range` (from the pot's x), its y uniform in `plate_y_range` (both arms carry it
    24-31 cm).

    **Success:** the pot was carried by both handles: at some control step each gripper held it (`ee.holds`
    for the left and the right) with its TCP within `handle_tol` of its own handle's centre while the pot's
    bottom was at least `lift_height` above the table and it was tilted by less than `max_tilt` (the
    LiftTwoHanded family's lift, `LiftTwoHandedTask`, by the handles; episode memory `carried`); and now
    the pot's centre is within `centre_tol` (horizontally) of the plate's centre, its bottom rests on the
    plate (within `rest_tol` of the plate's top), it is tilted by less than `max_tilt`, and neither gripper
    holds it.

    **Level 2:** (against Level 1's LiftWideBox, the same two-gripper lift: 2 stages, grasp and lift, 47
    steps mean, 15 degrees of tilt allowed): 4 stages, 137 steps mean (grasp both handles, lift, carry
    24-31 cm, set down and release), both arms' targets moving in lock-step through the ~80-step carry and
    set-down so that the pot stays within 10 degrees of level, and a 2 cm placement tolerance on the plate.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 10
    TASK_REGION = (-0.42, 0.2, -0.3, 0.3)
    PARAMS = LiftTwoHandedTask.PARAMS + ("centre_tol", "rest_tol", "handle_tol", "pot_x_range", "pot_y_range",
                                         "pot_max_yaw", "plate_dx_range", "plate_y_range")
    pot_shape = PotShape()
    plate_radius, plate_height = 0.11, 0.012
    # layout ranges as (low, span)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.pot = build_pot(self.scene, "pot", self.pot_shape, POT_DENSITY, color=(0.7, 0.72, 0.75, 1),
                             handle_color=(0.12, 0.12, 0.12, 1))
        self.plate = build_stove_plate(self.scene, "stove_plate", self.plate_radius, self.plate_height,
                                       color=(0.15, 0.15, 0.16, 1), ring_color=(0.75, 0.25, 0.1, 1))
        self.item = self.pot
        self.memory.flag("carried")  # lifted level by both grippers, each on its handle

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            pot = torch.stack([uniform(b, self.pot_x_range), uniform(b, self.pot_y_range), torch.zeros(b)], dim=1)
            self.pot.set_pose(Pose.create_from_pq(pot, yaw_quat((torch.rand(b) * 2 - 1) * np.deg2rad(self.pot_max_yaw))))
            (dx_lo, dx_hi) = self.plate_dx_range
            plate = torch.stack([pot[:, 0] + dx_lo + torch.rand(b) * (dx_hi - dx_lo), uniform(b, self.plate_y_range),
                                 torch.zeros(b)], dim=1)
            self.plate.set_pose(Pose.create_from_pq(plate))

    def handle_centres(self) -> dict[str, torch.Tensor]:
        """World centres of the left (+y) and right (-y) handle tabs, (num_envs, 3) each."""
        return {side: (self.pot.pose * Pose.create_from_pq(
            torch.as_tensor(self.pot_shape.handle_centre(sign), dtype=torch.float32, device=self.device)[None])).p
            for side, sign in SIDE_SIGNS.items()}

    def _on_handles(self, info: dict) -> torch.Tensor:
        """Adds `<side>_on_handle` to `info` (the family's lift info): the gripper holds the pot with its TCP
        within `handle_tol` of its own handle's centre; returns both."""
        handles = self.handle_centres()
        for side in SIDE_SIGNS:
            near = torch.linalg.norm(self.ee.tcp(side).p - handles[side], dim=1) <= self.handle_tol
            info[f"{side}_on_handle"] = info[f"{side}_grasped"] & near
        return info["left_on_handle"] & info["right_on_handle"]

    def _update_memory(self):
        # the holds (a contact pass each) only where the pot is up and level and not yet carried
        carried = self.memory["carried"]
        up = (self.pot.pose.p[:, 2] >= self.lift_height) & (tilt(self.pot) < np.deg2rad(self.max_tilt)) & ~carried
        if bool(up.any()):
            self.memory.latch("carried", up & self._on_handles(LiftTwoHandedTask.evaluate(self)))

    def _get_obs_extra(self, info: dict):
        return self.two_hand_obs(info, self.handle_centres(), "handle", dict(
            pot_pose=self.pot.pose.raw_pose, plate_pos=self.plate.pose.p,
            pot_to_plate=self.plate.pose.p - self.pot.pose.p))

    def evaluate(self):
        info = LiftTwoHandedTask.evaluate(self)  # the lift: height, tilt, each gripper's hold
        self._on_handles(info)
        offset = self.pot.pose.p - self.plate.pose.p
        info["is_centred"] = torch.linalg.norm(offset[:, :2], dim=1) <= self.centre_tol
        info["on_plate"] = (offset[:, 2] - self.plate_height).abs() <= self.rest_tol
        info["released"] = ~(info["left_grasped"] | info["right_grasped"])
        info["carried"] = self.memory["carried"]
        info["success"] = info["carried"] & info["is_centred"] & info["on_plate"] & info["is_level"] & info["released"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        handles = self.handle_centres()
        reward = torch.zeros(self.num_envs, device=self.device)
        for side in SIDE_SIGNS:
            reach = torch.linalg.norm(handles[side] - self.ee.tcp(side).p, dim=1)
            reward += (1 - torch.tanh(5 * reach)) + info[f"{side}_on_handle"]
        both = (info["left_on_handle"] & info["right_on_handle"]).float()
        lift = (info["height"] / self.lift_height).clamp(max=1) * (1 - info["tilt"] / np.pi)
        reward += both * lift
        # the carry counts once the pot has been lifted by both handles: above the plate, then down onto it
        gap = torch.linalg.norm((self.plate.pose.p - self.pot.pose.p)[:, :2], dim=1)
        placed = info["is_centred"] & info["on_plate"] & info["is_level"]
        reward += info["carried"] * (2 * (1 - torch.tanh(5 * gap)) + 2 * placed + info["released"] * placed)
        reward[info["success"]] = self.max_dense_reward
        return reward
