"""Stack6Blocks (L2 rigid SG, the StackBlocks family's one task): stack `num_blocks` cubes into one tower."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.building import actors
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg

# metres from the TCP: a block the gripper (hand or fingers) touches has its centre within this; the
# Panda hand is about 20 cm wide and its fingers 5 cm long
TOUCH_RADIUS = 0.15
BLOCK_COLORS = [
    (0.85, 0.15, 0.15, 1), (0.15, 0.6, 0.2, 1), (0.15, 0.35, 0.85, 1),
    (0.9, 0.75, 0.1, 1), (0.6, 0.2, 0.7, 1), (0.1, 0.7, 0.75, 1),
]


@register_task("Stack6Blocks")
class StackBlocksEnv(ManiLadderEnv):
    """**Task:** stack `num_blocks` cubes (2 x `half_size`) into a single tower (any order).

    **Randomisation:** block `i` starts in its own slot: its centre uniform in x in `block_<i>_x_range`, y in
    `block_<i>_y_range` (the catalog's six slots: a 2 x 3 grid 12 cm apart, each 4 x 4 cm, +-2 cm about its
    centre), each with a yaw uniform in `block_yaw_range` (a cube: every yaw). The slots keep any two blocks at
    least `min_block_spacing` apart (checked when the scene loads).

    **Success:** all `num_blocks` blocks form one tower: with the blocks sorted by height, the lowest rests on the table (centre within
    `z_tol` of one half-size) and each next block's centre is within `xy_tol` of the one below
    horizontally and one block size (+- `z_tol`) above it; every block is at rest (linear speed
    < `static_lin`, angular < `static_ang`) and the gripper touches none of them (`ee.touches`): the
    tower stands by itself, neither held nor propped up by the hand.

    **Rest thresholds:** they sit above the contact-solver vibration of a settled tower that has just been
    restored from a saved state (measured: up to 5.5 cm/s and 0.5 rad/s for several steps, until PhysX
    puts the blocks back to sleep), so a demo replayed from its recorded states keeps its success.

    **Level 2:** (against Level 1's single pick-and-place, PickPlacePen: 2 stages, grasp and place, 92 steps
    mean) five pick-and-place cycles in sequence (10 stages), ~465 steps (at most ~505; horizon 600), each block
    centred within `xy_tol` = 2 cm of the one below, and the six-block tower must end at rest by itself: one
    misplaced or knocked block undoes the earlier cycles.
    """

    TASK_REGION = (-0.2, 0.2, -0.3, 0.3)
    PARAMS = ("num_blocks", "half_size", "xy_tol", "z_tol", "static_lin", "static_ang", "block_yaw_range",
              "min_block_spacing") + tuple(f"block_{i}_{axis}_range" for i in range(len(BLOCK_COLORS)) for axis in "xy")

    @property
    def max_dense_reward(self) -> float:
        return 2 * self.num_blocks + 2

    def _load_scene(self, options: dict):
        if not 2 <= self.num_blocks <= len(BLOCK_COLORS):
            raise ValueError(f"num_blocks must be in [2, {len(BLOCK_COLORS)}], got {self.num_blocks}")
        self._check_slots_apart()
        super()._load_scene(options)
        self.blocks = [
            actors.build_cube(self.scene, half_size=self.half_size, color=BLOCK_COLORS[i], name=f"block_{i}",
                              initial_pose=Pose.create_from_pq([0, 0.1 * i, self.half_size]).sp)
            for i in range(self.num_blocks)
        ]

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            for i, block in enumerate(self.blocks):
                x_range, y_range = self._slot(i)
                xyz = torch.stack([uniform(b, x_range), uniform(b, y_range), torch.full((b,), self.half_size)], dim=1)
                block.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.block_yaw_range))))

    def _slot(self, i: int) -> tuple[tuple[float, float], tuple[float, float]]:
        """Block `i`'s start slot: its x and y ranges (m)."""
        return getattr(self, f"block_{i}_x_range"), getattr(self, f"block_{i}_y_range")

    def _check_slots_apart(self):
        """Raise unless every two of the used slots keep their blocks `min_block_spacing` apart wherever in their
        slots they land (the nearest points of two rectangles)."""
        for i in range(self.num_blocks):
            for j in range(i):
                gaps = [max(a[0] - b[1], b[0] - a[1], 0.0) for a, b in zip(self._slot(i), self._slot(j))]
                nearest = float(np.hypot(*gaps))
                if nearest < self.min_block_spacing and not np.isclose(nearest, self.min_block_spacing):
                    raise ValueError(f"slots {j} and {i} can put two blocks closer than min_block_spacing "
                                     f"{self.min_block_spacing} m (nearest {nearest:.3f} m)")

    def _block_positions(self) -> torch.Tensor:
        return torch.stack([blk.pose.p for blk in self.blocks], dim=1)  # (b, n, 3)

    def _any_block_touched(self, pos: torch.Tensor) -> torch.Tensor:
        """Whether the gripper touches any block. The contact query is costly on CPU, so it only runs for
        blocks near the TCP: a block the hand or fingers touch has its centre within TOUCH_RADIUS."""
        near = torch.linalg.norm(pos - self.ee.tcp().p[:, None], dim=2) < TOUCH_RADIUS
        touched = torch.zeros(len(pos), dtype=torch.bool, device=self.device)
        for i in near.any(dim=0).nonzero(as_tuple=True)[0].tolist():
            touched |= near[:, i] & self.ee.touches(self.blocks[i])
        return touched

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(block_poses=torch.cat([blk.pose.raw_pose for blk in self.blocks], dim=1))
        return obs

    def evaluate(self):
        pos = self._block_positions()
        order = torch.argsort(pos[..., 2], dim=1)
        tower = torch.gather(pos, 1, order[..., None].expand(-1, -1, 3))
        size = 2 * self.half_size
        on_table = (tower[:, 0, 2] - self.half_size).abs() <= self.z_tol
        xy_off = torch.linalg.norm(tower[:, 1:, :2] - tower[:, :-1, :2], dim=2)
        dz = tower[:, 1:, 2] - tower[:, :-1, 2]
        stacked_pairs = (xy_off <= self.xy_tol) & ((dz - size).abs() <= self.z_tol)  # (b, n-1)
        # progress for rewards and people: the most blocks in one column over a block on the table
        resting = (pos[..., 2] - self.half_size).abs() <= self.z_tol
        near = torch.cdist(pos[..., :2], pos[..., :2]) <= 2 * self.xy_tol
        column_size = torch.where(resting, near.sum(dim=2), torch.zeros_like(resting, dtype=torch.long)).max(dim=1).values
        is_static = torch.stack([blk.is_static(lin_thresh=self.static_lin, ang_thresh=self.static_ang) for blk in self.blocks], dim=1).all(1)
        any_touched = self._any_block_touched(pos)
        is_stacked = on_table & stacked_pairs.all(dim=1)
        return {
            "success": is_stacked & is_static & ~any_touched,
            "is_stacked": is_stacked,
            "column_size": column_size,
            "is_static": is_static,
            "any_touched": any_touched,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # progress = blocks in the tallest column; shaping pulls the TCP to the nearest block still on the table
        n = self.num_blocks
        progress = info["column_size"].float()
        pos = self._block_positions()
        loose = (pos[..., 2] - self.half_size).abs() <= self.z_tol
        dist = torch.linalg.norm(pos - self.ee.tcp().p[:, None], dim=2)
        reach = 1 - torch.tanh(5 * torch.where(loose, dist, torch.full_like(dist, 10)).min(dim=1).values)
        reward = 2 * progress + reach
        reward[info["success"]] = self.max_dense_reward
        return reward
