"""The ScoopBeans family's base: beans carried to a cup by a tool or a hand, counted by per-bean episode memory."""

from __future__ import annotations

import dataclasses

import torch

from maniladder_ms.deformables import particles


class ScoopBeansTask:
    """The ScoopBeans family's shared parts (ScoopBeansWithSpoon, CupBeansHands): `bean_count` beans of
    `bean_radius` (granular spheres) in `self.beans`, a cup `self.cup` of `cup_shape`, and per-bean episode
    memory `carried` (set by the task: which tool or hand carried the bean) against which beans in the cup
    are counted."""

    @property
    def particle_config(self) -> particles.ParticleConfig:
        return dataclasses.replace(particles.GRANULAR, count=self.bean_count, radius=self.bean_radius)

    def in_cup(self, positions: torch.Tensor | None = None) -> torch.Tensor:
        """Beans in the cup's inner volume, [B, N]; `positions`: the beans' (`beans.positions()`, read once a
        step by callers that test several regions: on the CPU reading 150 poses costs more than the tests)."""
        return self.cup_shape.inside(self.beans.positions() if positions is None else positions, self.cup.pose)

    def delivery_metrics(self, positions: torch.Tensor | None = None) -> dict:
        """Carried beans in the cup: `beans_delivered` (in the cup and carried), `beans_in_cup`, `beans_carried`,
        each (B,)."""
        carried = self.memory["carried"] > 0.5
        in_cup = self.in_cup(positions)
        return {"beans_delivered": (in_cup & carried).sum(dim=1), "beans_in_cup": in_cup.sum(dim=1),
                "beans_carried": carried.sum(dim=1)}
