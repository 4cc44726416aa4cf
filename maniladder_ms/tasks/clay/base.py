"""What the clay tasks share: `ClayTask`, a `ClayHolder` (plasticity and the clay's state in the env state;
`maniladder_ms.deformables.clay`) that also lays the clay out on the table at random."""

from __future__ import annotations

import torch

from maniladder_ms.deformables import clay


class ClayTask(clay.ClayHolder):
    """`clay.ClayHolder` for a task env (before `ManiLadderEnv` in its bases), with `reset_clay`: the task's
    clay placed at random on the table."""

    def reset_clay(self, env_idx: torch.Tensor, x: tuple, y: tuple, yaw: tuple, scale: tuple = (1.0, 1.15)):
        """Put `self.clay` back for the envs `env_idx`, its bottom centre on the table uniform in x = (low,
        high) and y, turned by a yaw uniform in `yaw` and scaled by a factor uniform in `scale` (`Clay.reset`)."""
        b, device = len(env_idx), self.device

        def uniform(low_high):
            low, high = low_high
            return low + torch.rand(b, device=device) * (high - low)

        origin = torch.stack([uniform(x), uniform(y), torch.full((b,), self.clay_config.radius, device=device)], dim=1)
        self.clay.reset(env_idx, origin, yaw=uniform(yaw), scale=uniform(scale))
