"""What the clay tasks share: `ClayTask`, a `ClayHolder` (plasticity and the clay's state in the env state;
`maniladder_ms.deformables.clay`) that also lays the clay out on the table at random."""

from __future__ import annotations

import torch

from maniladder_ms.deformables import clay
from maniladder_ms.layout import uniform, uniform_deg


class ClayTask(clay.ClayHolder):
    """`clay.ClayHolder` for a task env (before `ManiLadderEnv` in its bases), with `reset_clay`: the task's
    clay placed at random on the table, from the catalog params `CLAY_LAYOUT_PARAMS` (the task's `PARAMS`
    include them)."""

    CLAY_LAYOUT_PARAMS = ("clay_x_range", "clay_y_range", "clay_yaw_range", "clay_scale_range")

    def reset_clay(self, env_idx: torch.Tensor):
        """Put `self.clay` back for the envs `env_idx`, its bottom centre on the table uniform in x in
        `clay_x_range` and y in `clay_y_range`, turned by a yaw uniform in `clay_yaw_range` (deg) and scaled by a
        factor uniform in `clay_scale_range` (`Clay.reset`)."""
        b = len(env_idx)
        with torch.device(self.device):
            origin = torch.stack([uniform(b, self.clay_x_range), uniform(b, self.clay_y_range),
                                  torch.full((b,), self.clay_config.radius)], dim=1)
            self.clay.reset(env_idx, origin, yaw=uniform_deg(b, self.clay_yaw_range),
                            scale=uniform(b, self.clay_scale_range))
