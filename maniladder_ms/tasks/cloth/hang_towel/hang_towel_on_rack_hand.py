"""HangTowelOnRackHand (L2 deformable SX): one LEAP hand pinches a towel at the middle of a side edge, lifts it and
hangs it over a rack's bar."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from .base import HangTowelTask


@register_task("HangTowelOnRackHand")
class HangTowelOnRackHandEnv(HangTowelTask):
    """**Task:** a towel lies flat on the table in front of a towel rack (a horizontal bar along y on two
    posts); the LEAP hand pinches the towel, lifts it off the table, carries it over the bar, lays it onto
    the bar so it hangs down on both sides, and lets go.

    **Randomisation:**
    - the rack (bar top 20 cm above the table, a 2 cm rod 40 cm long between its posts) stands with its
      axis at x uniform in `bar_x_range`, y uniform in `bar_y_range`;
    - the towel (`cloth.towel(10, 8)`: 10 x 8 particles 2.5 cm apart, particles of 10 mm radius) lies flat,
      its centre at x uniform in `towel_x_range`, y uniform in `towel_y_range`, turned by a yaw uniform in
      +-`towel_max_yaw`.

    **Success:** the towel hangs over the bar: at least `min_side` of its particles on each side of the bar
    (beyond the vertical plane through the bar's axis, and lower than the bar's top `bar_height`; the
    bar's radius is `bar_radius`; `cloth.hanging_fractions`); none on the table (every particle's lowest
    point more than `table_gap` above it); the hand has let go (touches no towel particle, `ee.touches`);
    and at some step the hand held (`ee.holds`) a towel particle while the whole towel was off the table
    (every particle's lowest point more than `table_gap` up; episode memory `lifted`: the towel was carried,
    not pushed or dragged onto the bar).

    **Level 2:** (against Level 1's DragTowelHand on the same towel and hand: 2 stages, pinch a corner and drag
    the sheet over the table to a 4 cm goal, ~100 steps, the towel never leaves the table) 5 stages (pinch the
    middle of a side edge with the tips 5 mm into the sheet; lift the whole towel off the table; carry it ~25 cm
    over the 20 cm high bar; lay its ridge along the rod while shifting across it; let go) in ~276 steps. The
    drape has little room: 80 particles, >= 30% of them below the bar's top on each side and no more than ~40%
    left on or above the rod (a drape with 0.45+ on top piles and slides off when the fingers open), and the
    spheres roll over the 2 cm rod, so a drape off balance by one row (0.1 of the towel) drifts off after the
    release; a one-hand pinch at the towel's middle met that 32 times in 50.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    HOLD_MEMORY = "lifted"
    # towel start (centre plus its half diagonal) and the rack with its feet (bar axis x <= 0.06, feet 9.5 cm either side)
    TASK_REGION = (-0.38, 0.16, -0.28, 0.28)
    PARAMS = HangTowelTask.PARAMS + ("bar_x_range", "bar_y_range", "towel_x_range", "towel_y_range", "towel_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("lifted")  # the hand held a towel particle while the towel was off the table

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            bar = torch.stack([uniform(b, self.bar_x_range), uniform(b, self.bar_y_range), torch.zeros(b)], dim=1)
            self.bar.set_pose(Pose.create_from_pq(bar))
            centre = torch.stack([uniform(b, self.towel_x_range), uniform(b, self.towel_y_range),
                                  torch.full((b,), self.cloth_config.radius)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(self.towel_max_yaw)
            self.towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))

    def _update_memory(self):
        if self.memory["lifted"].all():
            return
        lowest = self.towel.positions()[..., 2].amin(dim=1) - self.cloth_config.radius
        off = lowest > self.table_gap
        if off.any():
            self.memory.latch("lifted", off & self.ee.holds(self.towel.spheres))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            points = self.towel.positions()
            obs.update(towel_points=points.flatten(1), bar_pos=self.bar.pose.p,
                       tcp_to_centre=points.mean(dim=1) - self.ee.tcp().p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        lifted = self.memory["lifted"]
        reach = torch.linalg.norm(self.towel.positions().mean(dim=1) - self.ee.tcp().p, dim=1)
        reward = torch.where(lifted, 1.0, 1 - torch.tanh(5 * reach)) + lifted.float()
        return self.add_hang_reward(reward, info)
