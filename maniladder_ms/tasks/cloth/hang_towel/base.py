"""The HangTowel family's base: a towel and a horizontal bar, and the rule that the towel hangs over it."""

from __future__ import annotations

import torch

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.objects.tabletop import build_towel_bar

ROWS, COLS = 10, 8  # rows along the towel's local x (across the bar), columns along its local y (along the bar)
BAR_HALF_LENGTH = 0.2  # the rod runs 20 cm to each side of its middle, posts under its ends
BAR_COLOR = (0.62, 0.62, 0.66, 1)
BAR_AXIS = (0.0, 1.0, 0.0)  # the rod lies along y: its sides are -x (the robot's, the towel's start) and +x


class HangTowelTask(ManiLadderEnv):
    """The HangTowel family's scene and rule: a towel (`cloth.towel(ROWS, COLS)`, a particle grid) and a fixed
    horizontal bar along y; the rule counts the particles hanging on each side of the bar
    (`cloth.hanging_fractions`), checks that none rests on (or within `table_gap` of) the table and that the
    end effectors let go. Variants set the agent and the start, and what memory the rule adds (`HOLD_MEMORY`:
    how the towel must have been taken)."""

    max_dense_reward = 6
    cloth_config = cloth.ClothConfig(radius=0.010)
    PARAMS = ("bar_height", "bar_radius", "min_side", "table_gap")
    HOLD_MEMORY: str  # the variant's episode-memory flag for how the towel must have been taken

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        layout = cloth.towel(ROWS, COLS, self.cloth_config.spacing)
        self.towel = cloth.build_cloth(self.scene, "towel", layout, self.cloth_config)
        self.bar = build_towel_bar(self.scene, "bar", self.bar_height, self.bar_radius, BAR_HALF_LENGTH, BAR_COLOR)

    def hanging(self, points: torch.Tensor | None = None) -> torch.Tensor:
        """Fractions of the towel's particles (`points`, default: their positions now) hanging on the near (-x)
        and far (+x) side of the bar, [B, 2]."""
        points = self.towel.positions() if points is None else points
        return cloth.hanging_fractions(points, self.bar.pose.p, torch.tensor(BAR_AXIS), self.bar_height)

    def evaluate_hang(self) -> dict:
        points = self.towel.positions()
        sides = self.hanging(points)
        lowest = points[..., 2].amin(dim=1) - self.cloth_config.radius
        touching = self.ee.touches(self.towel.spheres)
        hung = (sides >= self.min_side).all(dim=1)
        off_table = lowest > self.table_gap
        return dict(near_side=sides[:, 0], far_side=sides[:, 1], hung=hung, lowest=lowest, off_table=off_table,
                    is_touching=touching, success=hung & off_table & ~touching)

    def evaluate(self):
        info = self.evaluate_hang()
        info[self.HOLD_MEMORY] = self.memory[self.HOLD_MEMORY]
        info["success"] = info["success"] & info[self.HOLD_MEMORY]
        return info

    def add_hang_reward(self, reward: torch.Tensor, info: dict) -> torch.Tensor:
        """`reward` (the variant's reach and hold terms, [B]) plus the hang's: the scarcer side's fraction up to
        `min_side` (2), hung and off the table (0.5); `max_dense_reward` on success."""
        sides = torch.stack([info["near_side"], info["far_side"]], dim=1)
        reward += 2 * (sides.amin(dim=1) / self.min_side).clamp(0, 1)
        reward += (info["hung"] & info["off_table"]).float() * 0.5
        reward[info["success"]] = self.max_dense_reward
        return reward
