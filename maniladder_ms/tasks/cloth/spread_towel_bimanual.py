"""SpreadTowelBimanual (L1 deformable DG): both arms take the near corners of a rumpled towel and spread it
over a target area."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth, metrics
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.envs.memory import latch_held_by_both
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.tasks.cloth.base import SIDES

ROWS = COLS = 10
# the towel corner each arm takes (towel's named corners: 0 (-x, -y), 1 (-x, +y)): the two near the robot
CORNER = {"left": 1, "right": 0}
FOLD_CELLS = (4, 5)  # the near edge strip folded back: `cloth.fold_edge`'s cells (3 rows on top, or 4)


@register_task("SpreadTowelBimanual")
class SpreadTowelBimanualEnv(ManiLadderEnv):
    """**Task:** a towel lies rumpled on the table beyond a square target area of its own size: pushed
    away from the robot, turned, its edge on the robot's side folded back over the sheet. Each arm takes
    one of the two folded-back corners, and together they pull the towel open and back over the target
    and lay it down.

    **Randomisation:**
    - the target (25 cm square, the flat towel's footprint, axis-aligned) is centred at x uniform in
      `target_x_range`, y uniform in `target_y_range`;
    - the towel (10 x 10 particles, 2.5 cm apart, radius 10 mm so folded layers rest on the sheet) is
      centred further from the robot (+x) than the target by an x offset uniform in `towel_dx_range`, its y
      offset from the target's uniform in `towel_dy_range`, turned by a yaw uniform in +-`towel_max_yaw`; its
      edge strip on the robot's side (-x) is folded
      back over the sheet along a grid line (`cloth.fold_edge`, cells 4 or 5, uniform): 3 or 4 rows
      lie upside down one spacing (2.5 cm) above the sheet, the next row stands in the crease, so both
      near corner particles lie on top. The start never covers the target: with the offset alone at
      most (25 - 8) / 25 = 68% (0.17-0.38 measured on seeds 0-11, fold included).

    **Success:** the towel covers at least `min_coverage` of the target area (a square of half side
    `target_half`) seen from above, counting only particles lying on the table (centres at most
    `on_table_height` up; `metrics.target_coverage`, each particle a tile of the grid spacing), and at
    some step of the episode both grippers held (`ee.holds`) a corner particle of the towel at once
    (episode memory `corners_held`: the towel was spread by two corners, not pushed or dragged).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.25, -0.3, 0.3)
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("target_half", "min_coverage", "on_table_height", "target_x_range", "target_y_range", "towel_dx_range",
              "towel_dy_range", "towel_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        layout = cloth.towel(ROWS, COLS, self.cloth_config.spacing)
        self.towel = cloth.build_cloth(self.scene, "towel", layout, self.cloth_config)
        self.target = build_zone_marker(self.scene, "target", self.target_half, (0.95, 0.85, 0.55, 1))
        # the rumpled shapes, one per fold size
        shapes = [cloth.fold_edge(layout, ROWS, COLS, cells) for cells in FOLD_CELLS]
        self._shape_positions = torch.tensor(np.stack([p for p, _ in shapes]), dtype=torch.float32, device=self.device)
        self._shape_quats = torch.tensor(np.stack([q for _, q in shapes]), dtype=torch.float32, device=self.device)
        self.memory.flag("corners_held")  # both grippers held a towel corner at the same step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            target = torch.stack([uniform(b, self.target_x_range), uniform(b, self.target_y_range),
                                  torch.full((b,), MARKER_THICKNESS / 2)], dim=1)
            self.target.set_pose(Pose.create_from_pq(target))
            offset = torch.stack([uniform(b, self.towel_dx_range), uniform(b, self.towel_dy_range)], dim=1)
            centre = torch.cat([target[:, :2] + offset, torch.full((b, 1), self.cloth_config.radius)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(self.towel_max_yaw)
            shape = torch.randint(len(self._shape_positions), (b,))
            self.towel.set_shape(self._shape_positions[shape], self._shape_quats[shape],
                                 Pose.create_from_pq(centre, yaw_quat(yaw)))

    def corner_particles(self) -> dict:
        """The corner particle (actor) each arm takes, keyed by side."""
        return {side: self.towel.corner_spheres()[k] for side, k in CORNER.items()}

    def _update_memory(self):
        latch_held_by_both(self, "corners_held", self.towel.corner_spheres())

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        obs.update(left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            obs["towel_points"] = self.towel.positions().flatten(1)
            obs["target_pos"] = self.target.pose.p
            for side, particle in self.corner_particles().items():
                obs[f"{side}_tcp_to_corner"] = particle.pose.p - self.ee.tcp(side).p
        return obs

    def evaluate(self):
        coverage = metrics.target_coverage(self.towel.positions(), self.cloth_config.spacing, self.target.pose.p,
                                           (self.target_half, self.target_half), max_height=self.on_table_height)
        info = {f"{side}_grasped": self.ee.holds(particle, side) for side, particle in self.corner_particles().items()}
        corners_held = self.memory["corners_held"]
        info.update(success=(coverage >= self.min_coverage) & corners_held, coverage=coverage, corners_held=corners_held)
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        for side, particle in self.corner_particles().items():
            reach = torch.linalg.norm(particle.pose.p - self.ee.tcp(side).p, dim=1)
            reward += (1 - torch.tanh(5 * reach)) + info[f"{side}_grasped"].float()
        reward += 2 * (info["coverage"] / self.min_coverage).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
