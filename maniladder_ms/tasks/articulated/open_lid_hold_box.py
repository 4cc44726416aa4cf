"""OpenLidHoldBox (L1 rigid DG): one arm holds a light box still while the other opens its hinged lid."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.boxes import LiddedBoxShape, build_lidded_box, lid_angle
from maniladder_ms.geometry import tcp_quat


@register_task("OpenLidHoldBox")
class OpenLidHoldBoxEnv(ManiLadderEnv):
    """**Task:** a light, narrow box with a hinged lid lies lengthwise across the table; the left arm
    holds the box still by its left end while the right arm lifts the lid open by its lip.

    **Randomisation:** the box (inner 2 x `box_inner_half`, i.e. 16 cm long along y and 6 cm wide outside,
    walls `box_wall_height` high, `box_density`: about 0.25 kg with the lid; the lid is hinged across the
    top of the left (+y) end and overhangs the right end wall by a 3 cm lip) has its centre uniform in
    x in `box_x_range`, y in `box_y_range` and its long axis turned from y by a yaw uniform in +-`box_max_yaw`;
    the lid is closed.

    **Success:** the lid is open by at least `open_angle`; the box body has moved less than
    `max_displacement` (horizontally) from where it stood at the start of the episode (episode memory
    `box_start`); the left gripper holds the box body (`ee.holds`), and held it at every step the lid was
    open by more than `closed_angle` (episode memory `opened_unheld` never latched).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.15, -0.2, 0.2)
    # box_inner_half: 6 cm wide outside across the hinge axis (the box's y), so that one gripper closes across
    # the box at its hinge end below the lid; box_wall_height: 9 cm walls leave room for the fingers under the
    # lid; box_density: a 0.18 kg body, which opening the lid drags ~10 cm unless it is held
    PARAMS = ("open_angle", "max_displacement", "closed_angle", "box_inner_half", "box_wall_height", "box_density",
              "box_x_range", "box_y_range", "box_max_yaw")
    # TCP height of the holding grasp, 2.5 cm below the lid: the fingers (+-1 cm about the TCP) grip the side
    # walls clear of the lid, and the sideways hand, which reaches ~6 cm below its TCP on the wrist camera's
    # side, clears the table
    HOLD_HEIGHT = 0.065
    HOLD_IN_FROM_END = 0.02  # m the holding grasp lies in from the box's hinge end

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.box_shape = LiddedBoxShape(inner_half_size=self.box_inner_half, wall_height=self.box_wall_height)
        self.box = build_lidded_box(self.scene, "box", self.box_shape, self.box_density,
                                    color=(0.35, 0.55, 0.4, 1), lid_color=(0.5, 0.7, 0.5, 1))
        self.box_body = self.box.links_map["box_body"]
        self.memory.value("box_start", 3)  # the box's position at the start of the episode
        self.memory.flag("opened_unheld")  # the lid was open past `closed_angle` while the left did not hold the box

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.box_x_range), uniform(b, self.box_y_range), torch.zeros(b)], dim=1)
            yaw = np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.box_max_yaw)
            self.box.set_pose(Pose.create_from_pq(xyz, yaw_quat(yaw)))
            self.box.set_qpos(torch.zeros(b, 1))
            self.box.set_qvel(torch.zeros(b, 1))
            self.memory.store("box_start", xyz, env_idx)

    def _box_held(self) -> torch.Tensor:
        """(num_envs,) the left gripper holds the box's body."""
        return self.ee.holds(self.box_body, "left")

    def holding_grasp(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """World TCP pose (p, q) of the holding grasp and the box's +x axis (hinge side, the robot's left):
        a sideways hand pointing at the box's hinge end along the box's -x, fingers closing across the
        box's width (its y axis) on the side walls below the lid, `HOLD_IN_FROM_END` in from the end,
        `HOLD_HEIGHT` up."""
        rot = self.box.pose.to_transformation_matrix()[:, :3, :3]
        box_x, box_y = rot[:, :, 0], rot[:, :, 1]
        local = torch.tensor([[self.box_shape.outer_half_size[0] - self.HOLD_IN_FROM_END, 0.0, self.HOLD_HEIGHT]],
                             device=self.device)
        return (self.box.pose * Pose.create_from_pq(local)).p, tcp_quat(-box_x, -box_y), box_x

    def _displacement(self) -> torch.Tensor:
        return torch.linalg.norm((self.box.pose.p - self.memory["box_start"])[:, :2], dim=1)

    def _update_memory(self):
        lid_open = lid_angle(self.box) > np.deg2rad(self.closed_angle)
        self.memory.latch("opened_unheld", lid_open & ~self._box_held())

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   lid_angle=info["lid_angle"], box_held=info["box_held"])
        if "state" in self.obs_mode:
            obs.update(box_pose=self.box.pose.raw_pose, box_start=self.memory["box_start"])
        return obs

    def evaluate(self):
        angle = lid_angle(self.box)
        displacement = self._displacement()
        is_open = angle >= np.deg2rad(self.open_angle)
        is_still = displacement < self.max_displacement
        held = self._box_held()
        opened_unheld = self.memory["opened_unheld"]
        return {
            "success": is_open & is_still & held & ~opened_unheld,
            "lid_angle": angle,
            "displacement": displacement,
            "is_lid_open": is_open,
            "is_box_still": is_still,
            "box_held": held,
            "opened_unheld": opened_unheld,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        hold_p = self.holding_grasp()[0]
        reach_hold = 1 - torch.tanh(5 * torch.linalg.norm(hold_p - self.ee.tcp("left").p, dim=1))
        lip = self.box.links_map["box_lid"].pose * Pose.create_from_pq(
            torch.as_tensor(self.box_shape.lip_in_lid(), dtype=torch.float32, device=self.device))
        reach_lip = 1 - torch.tanh(5 * torch.linalg.norm(lip.p - self.ee.tcp("right").p, dim=1))
        opened = (info["lid_angle"] / np.deg2rad(self.open_angle)).clamp(0, 1)
        still = 1 - (info["displacement"] / self.max_displacement).clamp(max=1)
        reward = reach_hold + info["box_held"].float() + reach_lip * ~info["is_lid_open"] + 3 * opened * still
        reward[info["success"]] = self.max_dense_reward
        return reward

