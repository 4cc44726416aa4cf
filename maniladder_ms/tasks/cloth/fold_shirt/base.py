"""The FoldShirt family's base: a flat shirt on the table, folded when both sleeves lie within the body's outline and
the hem lies on the collar."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import cloth, shirt
from maniladder_ms.envs import ManiLadderEnv


class FoldShirtTask(ManiLadderEnv):
    """The FoldShirt family's scene and rule: a shirt (`cloth.shirt()`, the T-shaped single-layer particle sheet of
    `deformables.shirt`, particles of 10 mm radius so folded layers rest on the sheet) lies flat, collar away from
    the robot at yaw 0, centred at x uniform in `shirt_x_range`, y uniform in +-`shirt_max_y`, turned by a yaw
    uniform in +-`shirt_max_yaw`. It is folded when both sleeves are in: every particle of each sleeve lies within
    the body's outline seen from above (the rectangle of the body's particle centres plus half a tile, in the
    body's frame as its collar half lies now: `shirt.outline_excess`), give or take `outline_margin`; the hem lies
    on the collar: the top-down distance between each body column's hem and collar particles is, on average, at
    most `hem_tol` (`cloth.fold_distance(..., top_down=True)` over `shirt.hem_collar_pairs`); the shirt lies on
    the table (no particle centre higher than `max_height`: three layers where hem, sleeve and body lie on each
    other); and the end effectors have let go (touch no particle, `ee.touches`). Variants set the agent."""

    max_dense_reward = 6
    TASK_REGION = (-0.4, 0.05, -0.22, 0.22)  # shirt centres plus its half diagonal (18 cm) and a radius
    cloth_config = cloth.ClothConfig(radius=0.010)
    # particles resting on the table and, folded, on each other: PhysX contact caches are not state
    RESTORES_NEED_FRESH_SCENE = True
    PARAMS = ("outline_margin", "hem_tol", "max_height", "shirt_x_range", "shirt_max_y", "shirt_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        layout = cloth.shirt(spacing=self.cloth_config.spacing)
        self.shirt = cloth.build_cloth(self.scene, "shirt", layout, self.cloth_config)
        self.sleeves = {side: shirt.sleeve_ids(layout, side) for side in shirt.SIDES}
        self.hem_collar = shirt.hem_collar_pairs(layout)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            pose = shirt.draw_pose(b, self.shirt_x_range, self.shirt_max_y, self.shirt_max_yaw, self.cloth_config.radius)
            self.shirt.set_rest_shape(pose)

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in self.ee.sides}
        if "state" in self.obs_mode:
            obs.update(shirt_points=self.shirt.positions().flatten(1), hem_distance=info["hem_distance"])
        return obs

    def evaluate(self):
        points = self.shirt.positions()
        info = {}
        for side in shirt.SIDES:
            excess = shirt.outline_excess(points, self.shirt.layout, self.sleeves[side])
            info[f"{side}_sleeve_in"] = excess <= self.outline_margin
        hem_distance = cloth.fold_distance(points, self.hem_collar, top_down=True)
        on_table = points[..., 2].amax(dim=1) <= self.max_height
        touching = self.ee.touches(self.shirt.spheres)
        hem_on_collar = hem_distance <= self.hem_tol
        info.update(success=info["left_sleeve_in"] & info["right_sleeve_in"] & hem_on_collar & on_table & ~touching,
                    hem_distance=hem_distance, hem_on_collar=hem_on_collar, on_table=on_table, is_touching=touching)
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        points = self.shirt.positions()
        reward = torch.zeros(self.num_envs, device=self.device)
        # each sleeve towards the body, then the hem towards the collar, laid down and let go
        for side in shirt.SIDES:
            excess = shirt.outline_excess(points, self.shirt.layout, self.sleeves[side]).clamp(min=0)
            reward += 1 - torch.tanh(10 * excess)
        start = float(self.shirt.layout.positions[self.hem_collar[0][1], 0] - self.shirt.layout.positions[self.hem_collar[0][0], 0])
        reward += 3 * ((start - info["hem_distance"]) / (start - self.hem_tol)).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
