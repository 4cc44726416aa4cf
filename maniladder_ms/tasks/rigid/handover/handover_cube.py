"""HandoverCube (L1 rigid DG, family Handover): the left arm picks a cube and hands it to the right arm,
which places it in a target zone on the right."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.building import actors
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import top_down_quat
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, hand_over, line_up, tcp_quat
from maniladder_ms.solvers.driven import DrivenSolver

from .base import HandoverTask

@register_task("HandoverCube")
class HandoverCubeEnv(HandoverTask):
    """**Task:** the left arm picks up a cube on the left of the table and hands it over to the right arm
    in mid-air; the right arm puts it down in a square target zone on the right.

    **Randomisation:**
    - the cube (side 2 x `cube_half`) lies with a uniform random yaw, its centre uniform in x in [-0.15, 0.0],
      y in [0.15, 0.3] (in front of the left arm);
    - the target zone (visual-only square tile, side 2 x `zone_half`, axis-aligned) has its centre uniform in
      x in [-0.15, 0.0], y in [-0.32, -0.22] (in front of the right arm).

    **Success:** (the Handover family rule, `HandoverTask`) the cube was handed over: the right gripper held
    it (`ee.holds`) while the left gripper neither held nor touched it and its centre was at least
    `lift_height` above the table, after the left gripper had held it (episode memory `handed_over`); and
    now the cube centre lies inside the zone's square (|dx|, |dy| <= `zone_half`), the cube rests on the
    table (centre less than `on_table_tol` above `cube_half`) and neither gripper touches it (`ee.touches`).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 9
    TASK_REGION = (-0.25, 0.1, -0.4, 0.4)
    PARAMS = HandoverTask.PARAMS + ("cube_half", "zone_half", "on_table_tol")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.cube = actors.build_cube(self.scene, half_size=self.cube_half, color=(0.85, 0.2, 0.15, 1), name="cube",
                                      initial_pose=Pose.create_from_pq([0, 0.2, self.cube_half]).sp)
        self.zone = build_zone_marker(self.scene, "target_zone", self.zone_half, (0.2, 0.7, 0.3, 1))
        self.item, self.target = self.cube, self.zone

    def item_rest_height(self) -> float:
        return self.cube_half

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            cube_xyz = torch.stack([torch.rand(b) * 0.15 - 0.15, 0.15 + torch.rand(b) * 0.15,
                                    torch.full((b,), self.cube_half)], dim=1)
            self.cube.set_pose(Pose.create_from_pq(cube_xyz, yaw_quat(torch.rand(b) * np.pi / 2)))
            zone_xyz = torch.stack([torch.rand(b) * 0.15 - 0.15, -0.32 + torch.rand(b) * 0.1,
                                    torch.full((b,), MARKER_THICKNESS / 2)], dim=1)
            self.zone.set_pose(Pose.create_from_pq(zone_xyz))

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            obs.update(cube_pose=self.cube.pose.raw_pose, zone_pos=self.zone.pose.p,
                       cube_to_zone_pos=self.zone.pose.p - self.cube.pose.p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        cube_p = self.cube.pose.p
        left_reach = torch.linalg.norm(cube_p - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(cube_p - self.ee.tcp("right").p, dim=1)
        to_zone = torch.linalg.norm(self.zone.pose.p[:, :2] - cube_p[:, :2], dim=1)
        left_grasped, right_grasped = info["left_grasped"].float(), info["right_grasped"].float()
        # stages: left reaches and grasps; the right reaches the held cube and takes it; the right carries
        # it to the zone and lets go
        reward = (1 - torch.tanh(5 * left_reach)) + left_grasped
        reward = torch.where(left_grasped.bool() | right_grasped.bool(), reward.clamp(min=2), reward)
        reward += (1 - torch.tanh(5 * right_reach)) * left_grasped + 2 * right_grasped
        reward = torch.where(right_grasped.bool(), 5 + (1 - torch.tanh(5 * to_zone)), reward)
        reward = torch.where(info["placed"], 7 + (1 - right_grasped), reward)
        reward[info["success"]] = self.max_dense_reward
        return reward



MEET_POINT = (-0.05, 0.0, 0.2)  # cube centre during the handover, between the arms
GIVER_OFFSET = 0.013  # the left fingers hold the cube's left (+y) part, the right fingers its right part
TAKER_OFFSET = 0.015
PLACE_DROP = 0.015


def _face_yaw(cube, near: float) -> torch.Tensor:
    """The yaw of a cube face normal (mod 90 degrees) closest to `near`."""
    return near + torch.remainder(yaw_of(cube.pose.q) - near + np.pi / 4, np.pi / 2) - np.pi / 4


@register_solver("HandoverCube", control_modes=TCP_DELTA_MODES)
def solve_handover_cube(env, seed: int) -> dict:
    """Left: top-down grasp of the cube's +y part (fingers across a face pair), carry to the meeting point
    with the fingers closing along x. Right: horizontal grasp of the cube's -y part from the right, fingers
    also across x; left lets go and backs off upwards. Right: set the cube down in the zone, let go, back off."""
    with DrivenSolver.episode(env, seed) as s:
        task: HandoverCubeEnv = env.unwrapped
        device, n = task.device, task.num_envs
        y = torch.tensor([0.0, 1.0, 0.0], device=device)
        meet = torch.tensor([MEET_POINT], device=device).expand(n, 3)
        take_q = tcp_quat(y.expand(n, 3), torch.tensor([[1.0, 0.0, 0.0]], device=device).expand(n, 3))
        # the right arm turns its hand sideways and waits beside the meeting point while the left one picks
        line_up(s, Grasp("right_arm", "right_gripper", meet - TAKER_OFFSET * y, take_q, -0.1 * y))
        # the wrist turns by at most 45 degrees between the pick and the meeting point (yaw pi/2)
        pick_yaw = _face_yaw(task.cube, np.pi / 2)
        hand_x = torch.stack([torch.cos(pick_yaw), torch.sin(pick_yaw), torch.zeros_like(pick_yaw)], dim=1)
        grasp_p = task.cube.pose.p + GIVER_OFFSET * hand_x
        s.pick("left_arm", "left_gripper", grasp_p, pick_yaw, lift=0)
        # up off the table first, then straight to the meeting point
        s.move({"left_arm": (s.above(grasp_p, 0.05), s.tcp("left_arm").q)}, max_steps=20, pos_tol=0.02)
        s.move({"left_arm": (meet + GIVER_OFFSET * y, top_down_quat(np.pi / 2, n, device))}, max_steps=60)
        taker = Grasp("right_arm", "right_gripper", task.cube.pose.p - TAKER_OFFSET * y, take_q, -0.1 * y)
        hand_over(s, "left_arm", "left_gripper", taker, giver_retreat=torch.tensor([0.0, 0.05, 0.08], device=device))
        # put down over the zone centre; the sideways hand touches the table before the cube does, so the
        # cube is let go PLACE_DROP above it
        place = task.zone.pose.p - TAKER_OFFSET * y
        place[:, 2] = task.cube_half + PLACE_DROP
        s.move({"right_arm": (s.above(place, 0.05), take_q)}, max_steps=60, pos_tol=0.01)
        s.move({"right_arm": (place, take_q)}, max_steps=30)
        s.release("right_gripper", steps=5)
        s.move({"right_arm": (place - 0.08 * y, take_q)}, max_steps=20, pos_tol=0.02)
        s.hold_until_success()
        return s.info
