"""SqueezeClayBimanual (L1 deformable DG): squeeze a clay block narrower between two closed grippers."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import clay
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.tasks.clay.base import ClayTask

SIDES = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table
SQUEEZE_AXIS = (0.0, 1.0)  # world y, from one arm to the other


@register_task("SqueezeClayBimanual")
class SqueezeClayBimanualEnv(ClayTask, ManiLadderEnv):
    """**Task:** a block of clay (plastic: it keeps the shape it is pressed into) lies on the table between
    the two arms, its long side along the line between them; squeeze it from both sides with the closed
    grippers until it is narrower along that line.

    **Randomisation:** the block (3 x 5 x 3 particles on a 1.2 cm lattice, 3.6 x 6 x 3.6 cm, the 6 cm side
    along y) is scaled by a factor uniform in `clay_scale_range` (`Clay.reset`), turned by a yaw uniform in
    `clay_yaw_range`, its centre uniform in x in `clay_x_range`, y in `clay_y_range`.

    **Success:** the clay's width along the squeeze axis (world y; `clay.width_along`, the particles'
    extent with their radius) is at most `max_width_ratio` of its width at the start, and at some step
    of the episode both grippers pressed on the clay at once (`ee.touches`, episode memory
    `squeezed_both`: squeezed from both sides, not pushed narrower by one arm).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 5
    TASK_REGION = (-0.22, 0.02, -0.15, 0.15)
    # block_half: the particle centres' half extents (3 x 5 x 3 particles, the long side along y)
    PARAMS = ("block_half", "max_width_ratio") + ClayTask.CLAY_LAYOUT_PARAMS

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_block(self.block_half, self.clay_config.spacing))
        self.memory.flag("squeezed_both")  # both grippers pressed on the clay at the same step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self.reset_clay(env_idx)

    def width(self, points: torch.Tensor) -> torch.Tensor:
        axis = torch.tensor(SQUEEZE_AXIS, device=self.device)
        return clay.width_along(points, axis, self.clay_config.radius)

    def side_faces(self) -> dict[str, torch.Tensor]:
        """Table points (z = 0) at the middle of the clay's current outermost extent on each arm's side, [B, 3]."""
        points = self.clay.positions()
        middle = points.mean(dim=1) * torch.tensor([1.0, 1.0, 0.0], device=self.device)
        y = points[..., 1]
        faces = {}
        for side, sign in SIDES.items():
            face = middle.clone()
            face[:, 1] = (y.amax(dim=1) if sign > 0 else y.amin(dim=1)) + sign * self.clay_config.radius
            faces[side] = face
        return faces

    def _update_memory(self):
        if self.memory["squeezed_both"].all():
            return  # latched for good: spare the contact queries (45 particles a side)
        touched = {side: self.ee.touches(self.clay.spheres, side) for side in SIDES}  # one contact pass a side
        self.memory.latch("squeezed_both", touched["left"] & touched["right"])

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        if "state" in self.obs_mode:
            obs.update(clay_points=self.clay.positions().flatten(1), width_ratio=info["width_ratio"])
        return obs

    def evaluate(self):
        width_ratio = self.width(self.clay.positions()) / self.width(self.clay.start)
        squeezed_both = self.memory["squeezed_both"]
        return {"success": (width_ratio <= self.max_width_ratio) & squeezed_both, "width_ratio": width_ratio,
                "squeezed_both": squeezed_both}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        for side, face in self.side_faces().items():
            reward += 1 - torch.tanh(5 * torch.linalg.norm(face - self.ee.tcp(side).p, dim=1))
        squeeze = ((1 - info["width_ratio"]) / (1 - self.max_width_ratio)).clamp(0, 1)
        reward += 2 * squeeze
        reward[info["success"]] = self.max_dense_reward
        return reward
