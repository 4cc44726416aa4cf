"""UnfoldShirt (L3 deformable SG): unfold a folded shirt (sleeves in, hem up) so it lies flat, sleeves out."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from maniladder_ms.deformables import cloth, shirt
from maniladder_ms.envs import ManiLadderEnv, register_task


@register_task("UnfoldShirt")
class UnfoldShirtEnv(ManiLadderEnv):
    """**Task:** a shirt lies folded on the table, both sleeves folded over onto its body and its hem strip folded
    up over the body; unfold it: lay the hem back down by its corners, take each sleeve by its cuff, lift it off
    the body and lay it out beside the body, so the shirt lies flat with both sleeves out, and let go.

    **Randomisation:** the shirt (`cloth.shirt()`: a T-shaped single-layer sheet of particles 2.5 cm apart, a
    body of 8 x 6 particles (20 x 15 cm, collar away from the robot at yaw 0) with a sleeve of 3 x 3 beside its
    top three rows on each side, 66 particles, 30 cm across the sleeves; radius 10 mm so a folded layer rests on
    the sheet; `deformables.shirt` says what this proxy can and cannot do) starts folded (`shirt.fold`): both
    sleeves over onto the body along the seam (the column next to the body upright in the crease, the cuff and
    the column before it upside down on the body's two edge columns), and the hem strip up over the body by
    `hem_fold_cells` rows (3: the crease row upright, 2 rows upside down on the body's rows below the sleeves;
    a strip of 2 springs open by itself within 30 steps, the crease's bend drives lifting its one upper row, and
    one of 4 would land on the folded sleeves); centred at x uniform in `shirt_x_range`, y uniform in
    +-`shirt_max_y`, turned by a yaw uniform in +-`shirt_max_yaw`. The start covers 0.55 of the flat shirt's
    area; with the hem laid back it covers 0.77, and one sleeve laid out as well ~0.89: the area bound alone
    would pass with a sleeve still folded in, which is why both cuffs must be out.

    **Success:** the shirt's covered area seen from above (`cloth.coverage`: particle tiles of the spacing's size
    in the shirt's own grid axes) is at least `min_coverage` of its flat area (lies flat); both sleeves are out:
    every particle of each sleeve's cuff (its outermost column) lies beyond the body's outline on the sleeve's
    side, seen from above across the body as it lies now (`shirt.sleeve_out` positive); and the gripper touches no
    particle of the shirt (`ee.touches`: it lies so by itself).

    **Level 3:** its Level-2 suite-mate FoldTowelInHalf turns one half of a rectangle over with two corner
    carries; FlattenTowelCorner (Level 1) lays back one folded corner with one carry. Here three separate folded
    layers (the hem strip, each sleeve) must each be peeled off and turned over, in an order (the hem's corners
    lie under nothing, the sleeves' cuffs beside them), every carry picking a particle of an upper layer that
    rests on the body two radii (2 cm) up, 2.5 cm from its neighbours, and laying it at a place that only the
    body's current pose gives (the body slides under each carry), with a rule that checks both sleeves besides
    the area. Demos take ~356 steps of a 500-step horizon, 8 stages (pinch and carry four corners):
    T = 10 log10 356 + 8 = 33.5 against FoldTowelInHalf's 27.0 and FlattenTowelCorner's 21.
    """

    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.2, -0.25, 0.25)  # shirt centres plus its half diagonal (18 cm) and a radius
    cloth_config = cloth.ClothConfig(radius=0.010)
    # particles resting on the table and on each other (the folded sleeves): PhysX contact caches are not state
    RESTORES_NEED_FRESH_SCENE = True
    PARAMS = ("min_coverage", "hem_fold_cells", "shirt_x_range", "shirt_max_y", "shirt_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        layout = cloth.shirt(spacing=self.cloth_config.spacing)
        self.shirt = cloth.build_cloth(self.scene, "shirt", layout, self.cloth_config)
        positions, quats = shirt.fold(layout, self.hem_fold_cells)
        self._folded_positions = torch.tensor(positions, dtype=torch.float32, device=self.device)
        self._folded_quats = torch.tensor(quats, dtype=torch.float32, device=self.device)
        self.cuffs = {side: shirt.cuff_ids(layout, side) for side in shirt.SIDES}

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            pose = shirt.draw_pose(b, self.shirt_x_range, self.shirt_max_y, self.shirt_max_yaw, self.cloth_config.radius)
            self.shirt.set_shape(self._folded_positions, self._folded_quats, pose)

    def cuff_goals(self, side: str) -> torch.Tensor:
        """Where the sleeve's cuff particles lie when the shirt lies flat around its body as it lies now, [B, k, 2]."""
        return shirt.flat_place(self.shirt.positions(), self.shirt.layout, self.cuffs[side])

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(shirt_points=self.shirt.positions().flatten(1), coverage=info["coverage"])
            for side in shirt.SIDES:
                obs[f"{side}_cuff_goals"] = self.cuff_goals(side).flatten(1)
        return obs

    def evaluate(self):
        points = self.shirt.positions()
        coverage = cloth.coverage(points, self.shirt.layout, self.cloth_config.spacing)
        info = {f"{side}_sleeve_out": shirt.sleeve_out(points, self.shirt.layout, side) > 0 for side in shirt.SIDES}
        touching = self.ee.touches(self.shirt.spheres)
        flat = coverage >= self.min_coverage
        info.update(success=flat & info["left_sleeve_out"] & info["right_sleeve_out"] & ~touching,
                    coverage=coverage, flat=flat, is_touching=touching)
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        points = self.shirt.positions()
        tcp = self.ee.tcp().p
        reward = torch.zeros(self.num_envs, device=self.device)
        # reach a cuff of a sleeve still in, and bring each cuff towards its flat place
        reach = torch.full((self.num_envs,), np.inf, device=self.device)
        for side in shirt.SIDES:
            cuff = points[:, self.cuffs[side]]
            left_in = ~info[f"{side}_sleeve_out"]
            near = torch.linalg.norm(cuff - tcp[:, None], dim=-1).amin(dim=1)
            reach = torch.where(left_in, torch.minimum(reach, near), reach)
            way = torch.linalg.norm(cuff[..., :2] - self.cuff_goals(side), dim=-1).mean(dim=1)
            reward += 1 - torch.tanh(10 * way)
        reward += torch.where(torch.isfinite(reach), 1 - torch.tanh(5 * reach), torch.ones_like(reach))
        reward += 2 * ((info["coverage"] - 0.75) / (self.min_coverage - 0.75)).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
