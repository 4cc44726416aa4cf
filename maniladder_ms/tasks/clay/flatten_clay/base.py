"""The FlattenClay family's base: a ball of clay on the table to be flattened into a sheet."""

from __future__ import annotations

import torch

from maniladder_ms.deformables import clay, metrics
from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.tasks.clay.base import ClayTask


class FlattenClayTask(ClayTask, ManiLadderEnv):
    """A ball of clay (plastic: it keeps the shape it is pressed into; particles on a 1.2 cm lattice within
    `ball_radius`) lies on the table; flatten it.

    **Randomisation:** the ball's bottom centre uniform in x in `clay_x_range` and y in `clay_y_range` on the
    table, turned by a yaw uniform in `clay_yaw_range` and scaled by a factor uniform in `clay_scale_range`
    (`ClayTask.reset_clay`); each variant's catalog row gives the ranges.

    **Success** (the family's rule; a variant adds how the clay must have been flattened): the clay's height
    (`clay.height`: top of the highest particle above the bottom of the lowest) is <= `max_height_ratio` of its
    height at the start (`is_flat`), and its top-down footprint (`metrics.footprint_area`, one lattice-spacing
    tile per particle) is >= `min_area_ratio` times its footprint at the start (`is_spread`).
    """

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_ball(self.ball_radius, self.clay_config.spacing))

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self.reset_clay(env_idx)

    def height_ratio(self) -> torch.Tensor:
        """The clay's height now over its height at the start, [B]."""
        radius = self.clay_config.radius
        return clay.height(self.clay.positions(), radius) / clay.height(self.clay.start, radius)

    def shape_ratios(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The clay's height and footprint now over those at the start, [B] each (the family's measures)."""
        spacing = self.clay_config.spacing
        area = metrics.footprint_area(self.clay.positions(), spacing) / metrics.footprint_area(self.clay.start, spacing)
        return self.height_ratio(), area

    def flatness(self) -> dict[str, torch.Tensor]:
        """The family's rule: `is_flat`, `is_spread` and the two ratios they stand on, [B] each."""
        height_ratio, area_ratio = self.shape_ratios()
        return {
            "is_flat": height_ratio <= self.max_height_ratio,
            "is_spread": area_ratio >= self.min_area_ratio,
            "height_ratio": height_ratio,
            "area_ratio": area_ratio,
        }

    def shape_progress(self, info: dict) -> tuple[torch.Tensor, torch.Tensor]:
        """Dense reward terms in [0, 1]: how far the height ratio came down towards `max_height_ratio`, and the
        footprint ratio up towards `min_area_ratio`."""
        flatten = ((1 - info["height_ratio"]) / (1 - self.max_height_ratio)).clamp(0, 1)
        spread = ((info["area_ratio"] - 1) / (self.min_area_ratio - 1)).clamp(0, 1)
        return flatten, spread
