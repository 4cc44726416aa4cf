"""HangTowelOnBar (L2 deformable DG): both grippers lift a flat towel by two corners and drape it over a bar."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.envs.memory import latch_held_by_both
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.tasks.cloth.base import SIDES
from .base import ROWS, HangTowelTask

# the towel corner each arm takes (towel's named corners: 2 (+x, -y), 3 (+x, +y)): the two nearest the bar
CORNER = {"left": 3, "right": 2}


@register_task("HangTowelOnBar")
class HangTowelOnBarEnv(HangTowelTask):
    """**Task:** a towel lies flat on the table in front of a horizontal bar (a rod along y on two posts);
    each gripper takes the towel's corner on its side of the edge nearest the bar, together they lift the
    towel, carry it over the bar and lower it on the far side, so it hangs over the bar, and let go.

    **Randomisation:**
    - the bar (top 20 cm above the table, a 2 cm rod 40 cm long between its posts) stands with its axis at
      x uniform in `bar_x_range`, y 0;
    - the towel (`cloth.towel(10, 8)`: 10 x 8 particles 2.5 cm apart, 22.5 cm across the bar by 17.5 cm
      along it between particle centres, particles of 10 mm radius) lies flat on the robot's side of the
      bar, its edge nearest the bar short of the bar's axis by a gap uniform in `towel_gap_range`, centred at y
      uniform in `towel_y_range`, turned by a yaw uniform in +-`towel_max_yaw`.

    **Success:** the towel hangs over the bar: at least `min_side` of its particles on each side of the bar
    (beyond the vertical plane through the bar's axis, and lower than the bar's top `bar_height`; the
    bar's radius is `bar_radius`; `cloth.hanging_fractions`); none on the table (every particle's lowest
    point more than `table_gap` above it); both grippers have let go (neither touches a towel particle,
    `ee.touches`); and at some step both grippers held (`ee.holds`) a corner particle of the towel at once
    (episode memory `corners_held`: the towel was carried by two corners, not dragged over by one arm).

    **Level 2:** its Level-1 DG suite-mate SpreadTowelBimanual pulls a towel's two corners back over
    the table, 8 cm up, and lays them down (2 stages, horizon 150, a 75% coverage target, T = 10 log10 N + 2).
    Here the towel leaves the table: 5 stages (both corners pinched; lifted until the pinches are 24 cm up,
    4 cm over the 20 cm bar; carried 22-25 cm over it, the towel dragging up and over the 2 cm rod; lowered
    to 1 cm over its top on the far side; released and backed off without catching the sheet), both arms in
    lock-step the whole way (one arm ahead twists the sheet on the rod), and the result is judged after
    letting go: the 22.5 cm towel must leave at least 30% of its 80 particles hanging on each side of the rod
    (24 particles, three of its ten rows, below the rod's top; its halves hang ~10 cm) and clear the table on
    both sides; demos take ~190 steps of a 300-step horizon.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    HOLD_MEMORY = "corners_held"
    TASK_REGION = (-0.45, 0.08, -0.26, 0.26)  # towel start (centre plus its half diagonal) and the bar with its feet
    # (its feet reach 9.5 cm past the axis in x: 0.075 with the axis at its largest x, -0.02)
    PARAMS = HangTowelTask.PARAMS + ("bar_x_range", "towel_gap_range", "towel_y_range", "towel_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("corners_held")  # both grippers held a towel corner at the same step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            bar_x = uniform(b, self.bar_x_range)
            self.bar.set_pose(Pose.create_from_pq(torch.stack([bar_x, torch.zeros(b), torch.zeros(b)], dim=1)))
            half = (ROWS - 1) / 2 * self.cloth_config.spacing
            gap_lo, gap_hi = self.towel_gap_range  # drawn as bar_x - low - U * (high - low)
            centre = torch.stack([bar_x - gap_lo - torch.rand(b) * (gap_hi - gap_lo) - half,
                                  uniform(b, self.towel_y_range), torch.full((b,), self.cloth_config.radius)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(self.towel_max_yaw)
            self.towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))

    def corner_particles(self) -> dict:
        """The corner particle (actor) each arm takes, keyed by side."""
        return {side: self.towel.corner_spheres()[k] for side, k in CORNER.items()}

    def _update_memory(self):
        latch_held_by_both(self, "corners_held", self.towel.corner_spheres())

    def _get_obs_extra(self, info: dict):
        tcps = {side: self.ee.tcp(side) for side in SIDES}
        obs = {f"{side}_tcp_pose": tcp.raw_pose for side, tcp in tcps.items()}
        if "state" in self.obs_mode:
            corners = self.corner_particles()
            obs.update(towel_points=self.towel.positions().flatten(1), bar_pos=self.bar.pose.p,
                       **{f"{side}_tcp_to_corner": corners[side].pose.p - tcp.p for side, tcp in tcps.items()})
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        held = self.memory["corners_held"]
        for side, particle in self.corner_particles().items():
            reach = torch.linalg.norm(particle.pose.p - self.ee.tcp(side).p, dim=1)
            reward += torch.where(held, 1.0, 1 - torch.tanh(5 * reach))
        reward += held.float()
        return self.add_hang_reward(reward, info)
