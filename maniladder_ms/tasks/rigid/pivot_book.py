"""PivotBook (L1 rigid SG): pivot a book lying flat against a wall up until it stands on its end."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat

BOOK_DENSITY = 500.0


@register_task("PivotBook")
class PivotBookEnv(ManiLadderEnv):
    """**Task:** a book (2 x `book_half_size`, 21 x 15 x 3 cm, 0.47 kg) lies flat on the table with its
    far end against a wall; pivot it about that end until it stands upright against the wall.
    Non-prehensile: the book is too flat to grasp from the table.

    **Randomisation:** the book's centre y is uniform in +-`book_max_y`, its yaw uniform in +-`book_max_yaw`, and
    its far end between 0 and `max_start_wall_gap` from the wall (a 2 cm thick wall 8 cm high whose face is at
    x = 0.05).

    **Success:** the book's long axis is within `upright_tol` of vertical, its lower end's centre within
    `wall_gap` of the wall's face (it stands against the wall it was pivoted on, not anywhere on the
    table), the book is at rest (linear speed < `rest_speed`, angular speed < `rest_ang`) and stands
    by itself: the gripper does not touch it (`ee.touches`) and never held it (the episode memory's
    `held` latches on `ee.holds`: the pivot is non-prehensile).
    """

    max_dense_reward = 6

    TASK_REGION = (-0.2, 0.1, -0.31, 0.31)
    # book_half_size: long axis along local x; upright_tol in degrees
    PARAMS = ("book_half_size", "upright_tol", "wall_gap", "rest_speed", "rest_ang",
              "book_max_y", "book_max_yaw", "max_start_wall_gap")
    wall_face_x = 0.05
    wall_half_size = (0.01, 0.3, 0.04)  # 8 cm: enough to stop the book's foot, low enough for the front camera to see over

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        builder = self.scene.create_actor_builder()
        wall_pose = sapien.Pose(p=[self.wall_face_x + self.wall_half_size[0], 0, self.wall_half_size[2]])
        builder.add_box_collision(half_size=self.wall_half_size)
        builder.add_box_visual(half_size=self.wall_half_size,
                               material=sapien.render.RenderMaterial(base_color=[0.75, 0.75, 0.7, 1]))
        builder.initial_pose = wall_pose
        self.wall = builder.build_static(name="wall")
        builder = self.scene.create_actor_builder()
        # a cloth-bound cover grips: the finger sliding up the end face must lift the end by friction
        cover = sapien.physx.PhysxMaterial(static_friction=1.0, dynamic_friction=0.8, restitution=0)
        builder.add_box_collision(half_size=self.book_half_size, material=cover, density=BOOK_DENSITY)
        builder.add_box_visual(half_size=self.book_half_size,
                               material=sapien.render.RenderMaterial(base_color=[0.6, 0.15, 0.15, 1]))
        builder.initial_pose = sapien.Pose(p=[-0.05, 0, self.book_half_size[2]])
        self.book = builder.build(name="book")
        self.memory.flag("held")  # the gripper held the book at some step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            yaw = torch.deg2rad((torch.rand(b) - 0.5) * (2 * self.book_max_yaw))
            # the far end's corners touch the wall (or stop short by the gap) whatever the yaw
            reach = self.book_half_size[0] * torch.cos(yaw) + self.book_half_size[1] * torch.sin(yaw.abs())
            x = self.wall_face_x - reach - torch.rand(b) * self.max_start_wall_gap
            y = (torch.rand(b) - 0.5) * (2 * self.book_max_y)
            xyz = torch.stack([x, y, torch.full((b,), self.book_half_size[2])], dim=1)
            self.book.set_pose(Pose.create_from_pq(xyz, yaw_quat(yaw)))

    def book_axis(self) -> torch.Tensor:
        """(b, 3) world direction of the book's long axis (local +x, towards the wall when lying)."""
        return quaternion_apply(self.book.pose.q, torch.tensor([1.0, 0, 0], device=self.device).expand(self.num_envs, 3))

    def _update_memory(self):
        super()._update_memory()
        self.memory.latch("held", self.ee.holds(self.book))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(book_pose=self.book.pose.raw_pose, tcp_to_book_pos=self.book.pose.p - self.ee.tcp().p)
        return obs

    def evaluate(self):
        axis = self.book_axis()
        tilt_up = torch.asin(axis[:, 2].abs().clamp(max=1))  # 0 lying, pi/2 upright
        is_upright = tilt_up >= np.pi / 2 - np.deg2rad(self.upright_tol)
        # the centre of the lower end face (the foot it stands on when upright)
        down = torch.where(axis[:, 2:3] > 0, -axis, axis)
        foot = self.book.pose.p + down * self.book_half_size[0]
        is_at_wall = self.wall_face_x - foot[:, 0] <= self.wall_gap
        is_static = self.book.is_static(lin_thresh=self.rest_speed, ang_thresh=self.rest_ang)
        is_touched = self.ee.touches(self.book)
        held = self.memory["held"]
        return {"success": is_upright & is_at_wall & is_static & ~is_touched & ~held, "tilt_up": tilt_up,
                "is_upright": is_upright, "is_at_wall": is_at_wall, "is_static": is_static, "is_touched": is_touched,
                "held": held}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach the book's near end, then raise it; full marks once it stands still
        near_end = self.book.pose.p - self.book_axis() * self.book_half_size[0]
        reach = 1 - torch.tanh(5 * torch.linalg.norm(near_end - self.ee.tcp().p, dim=1))
        reward = reach + 3 * info["tilt_up"] / (np.pi / 2) + info["is_upright"].float()
        reward[info["success"]] = self.max_dense_reward
        return reward
