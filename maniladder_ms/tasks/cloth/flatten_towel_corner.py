"""FlattenTowelCorner (L1 deformable SG): unfold the one folded-over corner of a towel lying on the table."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform

ROWS = COLS = 10


@register_task("FlattenTowelCorner")
class FlattenTowelCornerEnv(ManiLadderEnv):
    """**Task:** a square towel lies flat on the table with one corner folded over onto it; unfold the
    corner (pinch it, lift it and lay it back at its flat place) so the towel covers its flat area again.

    **Randomisation:**
    - the towel (`cloth.towel(10, 10)`: 25 cm square, 2.5 cm particle spacing, particles of 1 cm radius:
      a folded layer rests on the sheet only above spacing / (2 sqrt 2), see `cloth.ClothConfig`) has
      one of its four corners, uniform, folded over (`cloth.fold_corner`, a rounded fold) across the
      diagonal line a number of grid steps from it drawn uniformly from `fold_cells` ({6, 7}: 21 or 28 of
      the 100 particles turned over, the towel covering 86% or 80% of its flat area once the layer has
      settled);
    - the towel's centre is at x uniform in `towel_x_range`, y uniform in +-`towel_max_y`, its edges turned by
      a yaw uniform in +-`towel_max_yaw` (with the corner choice, the fold points any way).

    **Success:** the towel's covered area seen from above (`cloth.coverage`: particle tiles of the
    spacing's size in the towel's own grid axes) is at least `min_coverage` of its flat area; the corner
    was carried: at some step the gripper held (`ee.holds`) the folded corner particle while it had come
    at least `carry_share` of its start distance towards its flat place (episode memory `carried`); and
    the gripper has let go of it (does not hold it now).
    """

    max_dense_reward = 5
    TASK_REGION = (-0.28, 0.18, -0.26, 0.26)  # towel centres plus the towel's half diagonal
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("fold_cells", "min_coverage", "carry_share", "towel_x_range", "towel_max_y", "towel_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.towel = cloth.build_cloth(self.scene, "towel", cloth.towel(ROWS, COLS, self.cloth_config.spacing),
                                       self.cloth_config)
        corners = self.towel.layout.named["corners"]
        self.corner_ids = torch.tensor(corners, device=self.device)
        # the adjacent and opposite corners of each corner: its flat place is adjacent + adjacent - opposite
        self.corner_frame = torch.tensor([[corners[a] for a in (1, 2, 3)], [corners[a] for a in (0, 3, 2)],
                                          [corners[a] for a in (0, 3, 1)], [corners[a] for a in (1, 2, 0)]],
                                         device=self.device)
        shapes = [cloth.fold_corner(self.towel.layout, ROWS, COLS, cells, 2.2 * self.cloth_config.radius, corner)
                  for cells in self.fold_cells for corner in range(4)]  # index: cells choice * 4 + corner
        self.fold_positions = torch.tensor(np.stack([p for p, _ in shapes]), dtype=torch.float32, device=self.device)
        self.fold_quats = torch.tensor(np.stack([q for _, q in shapes]), dtype=torch.float32, device=self.device)
        self.folded_corner = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self.memory.value("start_distance")
        self.memory.flag("carried")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            corner = torch.randint(0, 4, (b,))
            shape = torch.randint(0, len(self.fold_cells), (b,)) * 4 + corner
            yaw = symmetric_deg(b, self.towel_max_yaw)
            xyz = torch.stack([uniform(b, self.towel_x_range), (torch.rand(b) * 2 - 1) * self.towel_max_y,
                               torch.full((b,), self.cloth_config.radius)], dim=1)
            self.towel.set_shape(self.fold_positions[shape], self.fold_quats[shape], Pose.create_from_pq(xyz, yaw_quat(yaw)))
            self.folded_corner[env_idx] = corner
            self.memory.store("start_distance", self._corner_distance()[env_idx, None], env_idx)

    def corner_point(self) -> torch.Tensor:
        """Centre of the folded corner's particle, [B, 3]."""
        points = self.towel.positions()
        return points[torch.arange(len(points), device=self.device), self.corner_ids[self.folded_corner]]

    def corner_goal(self) -> torch.Tensor:
        """The folded corner's flat place, [B, 3]: completing the parallelogram of the three other corners
        (where the towel lies now, not where it was laid at reset)."""
        points = self.towel.positions()
        frame = points[torch.arange(len(points), device=self.device)[:, None], self.corner_frame[self.folded_corner]]
        return frame[:, 0] + frame[:, 1] - frame[:, 2]

    def _corner_distance(self) -> torch.Tensor:
        """Distance from the folded corner to its flat place in the table plane, [B]."""
        return torch.linalg.norm((self.corner_point() - self.corner_goal())[:, :2], dim=1)

    def _corner_held(self) -> torch.Tensor:
        """The gripper holds the folded corner particle, [B]."""
        held = torch.stack([self.ee.holds(self.towel.spheres[i]) for i in self.corner_ids.tolist()], dim=1)
        return held[torch.arange(len(held), device=self.device), self.folded_corner]

    def _update_memory(self):
        came = self._corner_distance() <= (1 - self.carry_share) * self.memory["start_distance"][:, 0]
        self.memory.latch("carried", came & self._corner_held())

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(towel_points=self.towel.positions().flatten(1), corner_pos=self.corner_point(),
                       corner_goal=self.corner_goal(), coverage=info["coverage"])
        return obs

    def evaluate(self):
        coverage = cloth.coverage(self.towel.positions(), self.towel.layout, self.cloth_config.spacing)
        is_grasped, carried = self._corner_held(), self.memory["carried"]
        return {
            "success": (coverage >= self.min_coverage) & carried & ~is_grasped,
            "coverage": coverage,
            "carried": carried,
            "is_grasped": is_grasped,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        corner = self.corner_point()
        reward = 1 - torch.tanh(5 * torch.linalg.norm(corner - self.ee.tcp().p, dim=1))
        reward += info["is_grasped"]
        reward += 1 - torch.tanh(5 * torch.linalg.norm(corner[:, :2] - self.corner_goal()[:, :2], dim=1))
        reward += 2 * ((info["coverage"] - 0.75) / (self.min_coverage - 0.75)).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
