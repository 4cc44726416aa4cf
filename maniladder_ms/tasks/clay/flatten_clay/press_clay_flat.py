"""PressClayFlat (L1 deformable SG): press a ball of clay into a flat disk with the closed gripper."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.envs import register_task
from maniladder_ms.tasks.clay.flatten_clay.base import FlattenClayTask


@register_task("PressClayFlat")
class PressClayFlatEnv(FlattenClayTask):
    """**Task:** a ball of clay (plastic: it keeps the shape it is pressed into) lies on the table; press
    it into a flat disk with the closed gripper's fingertips.

    **Randomisation:** the ball (particles on a 1.2 cm lattice within `ball_radius`: 81 of them, 6 cm
    across) is scaled by a factor uniform in `clay_scale_range` (`Clay.reset`), turned by a yaw uniform in
    `clay_yaw_range` (the lattice's axes: a quarter turn), its centre uniform in x in `clay_x_range`, y in
    `clay_y_range`.

    **Success:** the clay's height (`clay.height`: top of the highest particle above the bottom of the
    lowest) is <= `max_height_ratio` of its height at the start, and its top-down footprint
    (`metrics.footprint_area`, one lattice-spacing tile per particle) is >= `min_area_ratio` times its
    footprint at the start; and the gripper pressed it flat: at some step the clay was that flat while
    the closed gripper (each finger open at most `closed_opening`) touched it (`ee.touches`; episode
    memory `pressed_flat`).
    """

    max_dense_reward = 5
    TASK_REGION = (-0.17, 0.12, -0.22, 0.22)  # ball centres plus a flattened disk's radius
    PARAMS = ("ball_radius", "max_height_ratio", "min_area_ratio", "closed_opening") + FlattenClayTask.CLAY_LAYOUT_PARAMS

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("pressed_flat")

    def clay_center(self) -> torch.Tensor:
        """Table point (z = 0) under the clay's centre of mass, [B, 3]."""
        return self.clay.positions().mean(dim=1) * torch.tensor([1.0, 1.0, 0.0], device=self.device)

    def highest_point(self) -> torch.Tensor:
        """Table point (z = 0) under the highest particle, [B, 3]."""
        points = self.clay.positions()
        top = points[..., 2].argmax(dim=1)
        return points[torch.arange(len(points), device=self.device), top] * torch.tensor([1.0, 1.0, 0.0], device=self.device)

    def gripper_closed(self) -> torch.Tensor:
        """Both fingers open at most `closed_opening`, [B]. (Local: the vocabulary has `is_open` only.)"""
        q = self.agent.robot.get_qpos()[:, self.ee["main"].finger_joints]
        return (q <= self.closed_opening).all(dim=1)

    def _update_memory(self):
        candidate = (self.height_ratio() <= self.max_height_ratio) & self.gripper_closed()
        if bool(candidate.any()):  # the contact query (one pass per particle on the CPU) only when it can matter
            self.memory.latch("pressed_flat", candidate & self.ee.touches(self.clay.spheres))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(clay_points=self.clay.positions().flatten(1), height_ratio=info["height_ratio"],
                       area_ratio=info["area_ratio"])
        return obs

    def evaluate(self):
        shape = self.flatness()
        pressed_flat = self.memory["pressed_flat"]
        return {
            "success": shape["is_flat"] & shape["is_spread"] & pressed_flat,
            "pressed_flat": pressed_flat,
            **shape,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        top = self.clay_center()
        top[:, 2] = self.clay.positions()[..., 2].amax(dim=1)
        reach = 1 - torch.tanh(5 * torch.linalg.norm(top - self.ee.tcp().p, dim=1))
        flatten, spread = self.shape_progress(info)
        reward = reach + 2 * flatten + spread
        reward[info["success"]] = self.max_dense_reward
        return reward
