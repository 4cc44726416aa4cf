"""The FoldTowel family's base: a towel on the table, folded when the particles a fold pairs lie together."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform


class FoldTowelTask(ManiLadderEnv):
    """The FoldTowel family's scene and rule: a towel (`cloth.towel(*GRID)`, a particle grid) on the table; it is
    folded when, for one of the variant's folds (`fold_pair_sets`: lists of particle pairs a fold lays together),
    the paired particles lie, on average, at most `fold_tol` from each other seen from above
    (`cloth.fold_distance(..., top_down=True)`: the two layers keep two particle radii between them, which is the
    cloth's thickness, not a fold error); the towel lies on the table (no particle centre higher than
    `max_height` above it); and the end effectors have let go (touch no particle, `ee.touches`). Variants set the
    agent, `GRID`, the folds and the start."""

    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("fold_tol", "max_height")
    # particles resting on the table (and, folded, on each other): two restores of one state part by 5e-5 within
    # 5 steps on PhysX contact caches alone (test_state_round_trip_after_50_steps)
    RESTORES_NEED_FRESH_SCENE = True
    GRID: tuple[int, int]  # the towel's particle rows (its local x) and columns

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.towel = cloth.build_cloth(self.scene, "towel", cloth.towel(*self.GRID, self.cloth_config.spacing),
                                       self.cloth_config)
        self.folds = self.fold_pair_sets()

    def fold_pair_sets(self) -> list:
        """The folds that count, each the list of particle pairs it lays together (of the `GRID` towel)."""
        raise NotImplementedError

    def fold_error(self, points: torch.Tensor | None = None) -> torch.Tensor:
        """Mean top-down distance between the particles a fold pairs, of the best of the variant's folds, [B]
        (of the towel's particle positions `points`, default: read now)."""
        points = self.towel.positions() if points is None else points
        return torch.stack([cloth.fold_distance(points, pairs, top_down=True) for pairs in self.folds]).amin(0)

    def evaluate(self):
        points = self.towel.positions()
        fold_error = self.fold_error(points)
        on_table = points[..., 2].amax(dim=1) <= self.max_height
        touching = self.ee.touches(self.towel.spheres)
        return {
            "success": (fold_error <= self.fold_tol) & on_table & ~touching,
            "fold_error": fold_error,
            "folded": fold_error <= self.fold_tol,
            "on_table": on_table,
            "is_touching": touching,
        }

    def fold_progress(self, info: dict) -> torch.Tensor:
        """How far the fold has closed, [B] in [0, 1]: 0 at the flat towel's mean pair distance (about half the
        towel's rows times twice the spacing), 1 at `fold_tol`."""
        start = self.GRID[0] // 2 * self.cloth_config.spacing * 2
        return ((start - info["fold_error"]) / (start - self.fold_tol)).clamp(0, 1)


class TowelInHalfTask(FoldTowelTask):
    """A rectangular towel (`cloth.towel(10, 6)`, 25 x 15 cm) folded in half along its short axis (short edge onto
    short edge): the scene, layout, fold, observations and reward its variants (one per agent) share. The
    towel lies flat, centred at x uniform in `towel_x_range`, y uniform in +-`towel_max_y`, its long axis turned
    by a yaw uniform in +-`towel_max_yaw` (each variant's catalog row gives them)."""

    max_dense_reward = 5
    TASK_REGION = (-0.28, 0.14, -0.22, 0.22)  # towel centres plus the towel's half diagonal (14.6 cm) and a radius
    GRID = (10, 6)  # rows along the towel's long axis (its local x), columns along its short axis
    PARAMS = FoldTowelTask.PARAMS + ("towel_x_range", "towel_max_y", "towel_max_yaw")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            yaw = symmetric_deg(b, self.towel_max_yaw)
            xyz = torch.stack([uniform(b, self.towel_x_range), (torch.rand(b) * 2 - 1) * self.towel_max_y,
                               torch.full((b,), self.cloth_config.radius)], dim=1)
            self.towel.set_rest_shape(Pose.create_from_pq(xyz, yaw_quat(yaw)))

    def fold_pair_sets(self) -> list:
        """The short-axis fold: rows mirrored about the middle, the two short edges together."""
        return [cloth.fold_pairs(*self.GRID, axis=0)]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(towel_points=self.towel.positions().flatten(1), fold_error=info["fold_error"])
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        points = self.towel.positions()
        # reach the nearest short-edge corner, then bring the paired rows together, lay it down and let go
        corners = points[:, self.towel.layout.named["corners"]]
        reach = torch.linalg.norm(corners - self.ee.tcp().p[:, None], dim=-1).amin(dim=1)
        reward = 1 - torch.tanh(5 * reach)
        reward += 3 * self.fold_progress(info)
        reward += (info["folded"] & info["on_table"] & ~info["is_touching"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
