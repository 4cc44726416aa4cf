"""PushBlocksBimanual (L1 rigid DG): each arm pushes its own block into its own target zone."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.building import actors
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker

SIDES = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table
BLOCK_COLORS = {"left": (0.85, 0.5, 0.1, 1), "right": (0.15, 0.35, 0.85, 1)}
ZONE_COLORS = {"left": (0.95, 0.8, 0.5, 1), "right": (0.55, 0.7, 0.95, 1)}


@register_task("PushBlocksBimanual")
class PushBlocksBimanualEnv(ManiLadderEnv):
    """**Task:** two blocks lie on the table, one in front of each arm, each with a target zone of its
    own colour on the same side; each arm pushes its block into its zone (non-prehensile: the block may
    not be lifted).

    **Randomisation:** per side (left: y > 0, right: y < 0, mirrored ranges; both blocks are always placed, one in
    front of each arm: the sides are the task's, not drawn):
    - the block (5 cm cube) has its centre uniform in x in `block_x_range`, |y| in `block_abs_y_range`, and
      its yaw uniform in `block_yaw_range` (a cube: every yaw);
    - its zone (12 cm square tile, axis-aligned) is centred a distance uniform in `zone_distance_range` away from
      the block, in a direction within `zone_max_turn` (uniform) of straight ahead (+x), turned away from the
      centre line.

    **Success:** each block's centre lies inside its own zone shrunk by `margin` on every side (|dx|, |dy|
    <= `zone_half` - `margin` from the zone centre) and the block is on the table (centre less than
    `on_table_tol` above `block_half`); and each block was pushed by its own arm: its gripper touched it
    (`ee.touches`), the other arm's never did, and no gripper ever held a block (`ee.holds`) (episode
    memory `{side}_pushed`, `{side}_crossed`, `grasped`).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 8
    TASK_REGION = (-0.25, 0.1, -0.4, 0.4)
    PARAMS = ("block_half", "zone_half", "margin", "on_table_tol",
              "block_x_range", "block_abs_y_range", "block_yaw_range", "zone_distance_range", "zone_max_turn")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.blocks, self.zones = {}, {}
        for side, sign in SIDES.items():
            self.blocks[side] = actors.build_cube(
                self.scene, half_size=self.block_half, color=BLOCK_COLORS[side], name=f"{side}_block",
                initial_pose=Pose.create_from_pq([-0.15, sign * 0.2, self.block_half]).sp)
            self.zones[side] = build_zone_marker(self.scene, f"{side}_zone", self.zone_half, ZONE_COLORS[side])
            self.memory.flag(f"{side}_pushed")  # this side's gripper has touched its block
            self.memory.flag(f"{side}_crossed")  # the other side's gripper has touched it
        self.memory.flag("grasped")  # a gripper has held a block (pushing is non-prehensile)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            for side, sign in SIDES.items():
                block = torch.stack([uniform(b, self.block_x_range), sign * uniform(b, self.block_abs_y_range),
                                     torch.full((b,), self.block_half)], dim=1)
                self.blocks[side].set_pose(Pose.create_from_pq(block, yaw_quat(uniform_deg(b, self.block_yaw_range))))
                heading = sign * torch.rand(b) * np.pi / (180 / self.zone_max_turn)  # pi / 6: float32 as drawn
                distance = uniform(b, self.zone_distance_range)
                zone = block + torch.stack([torch.cos(heading), torch.sin(heading), torch.zeros(b)], dim=1) * distance[:, None]
                zone[:, 2] = MARKER_THICKNESS / 2
                self.zones[side].set_pose(Pose.create_from_pq(zone))

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        if "state" in self.obs_mode:
            for side in SIDES:
                obs[f"{side}_block_pose"] = self.blocks[side].pose.raw_pose
                obs[f"{side}_zone_pos"] = self.zones[side].pose.p
                obs[f"{side}_block_to_zone"] = self.zones[side].pose.p - self.blocks[side].pose.p
        return obs

    def _update_memory(self):
        blocks = list(self.blocks.values())
        self.memory.latch("grasped", self.ee.holds(blocks))
        for side, other in (("left", "right"), ("right", "left")):
            self.memory.latch(f"{side}_pushed", self.ee.touches(self.blocks[side], side))
            self.memory.latch(f"{side}_crossed", self.ee.touches(self.blocks[side], other))

    def evaluate(self):
        info = {}
        grasped = self.memory["grasped"]
        for side in SIDES:
            offset = self.blocks[side].pose.p - self.zones[side].pose.p
            in_zone = (offset[:, :2].abs() <= self.zone_half - self.margin).all(dim=1)
            on_table = self.blocks[side].pose.p[:, 2] < self.block_half + self.on_table_tol
            info[f"{side}_in_zone"] = in_zone & on_table
            info[f"{side}_pushed"] = self.memory[f"{side}_pushed"]
            info[f"{side}_crossed"] = self.memory[f"{side}_crossed"]
        own_pushes = info["left_pushed"] & info["right_pushed"] & ~info["left_crossed"] & ~info["right_crossed"]
        info["grasped"] = grasped
        info["success"] = info["left_in_zone"] & info["right_in_zone"] & own_pushes & ~grasped
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        for side in SIDES:
            block_p, zone_p = self.blocks[side].pose.p, self.zones[side].pose.p
            heading = torch.nn.functional.normalize((zone_p - block_p)[:, :2], dim=1)
            # the TCP belongs behind the block, on the far side from the zone
            behind = block_p[:, :2] - heading * (self.block_half + 0.02)
            reach = torch.linalg.norm(behind - self.ee.tcp(side).p[:, :2], dim=1)
            to_zone = torch.linalg.norm((zone_p - block_p)[:, :2], dim=1)
            reward += (1 - torch.tanh(5 * reach)) + 2 * (1 - torch.tanh(5 * to_zone)) + info[f"{side}_in_zone"]
        reward[info["success"]] = self.max_dense_reward
        return reward
