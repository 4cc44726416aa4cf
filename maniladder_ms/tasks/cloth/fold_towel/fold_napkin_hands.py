"""FoldNapkinHands (L2 deformable DX): two LEAP hands fold a square napkin diagonally into a triangle, one hand
pinning the far corner while the other lays the opposite corner onto it."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import register_task
from maniladder_ms.envs.memory import latch_held_by_both
from maniladder_ms.tasks.cloth.base import SIDES, lay_between_hands, side_corners
from .base import FoldTowelTask


@register_task("FoldNapkinHands")
class FoldNapkinHandsEnv(FoldTowelTask):
    """**Task:** a square napkin lies flat on the table between the two arms, one corner towards each arm;
    fold it diagonally into a triangle with both hands: one hand holds the corner on its side down while the
    other takes the opposite corner, lifts it over the napkin and lays it onto the held corner, then both let go.

    **Randomisation:** the napkin (`cloth.towel(8, 8)`: 2.5 cm particle spacing, particles of 1 cm radius,
    17.5 cm between corner centres, 24.7 cm across the diagonal) lies flat, its centre at x uniform in
    `towel_x_range`, y uniform in `towel_y_range`, its edges turned by a yaw uniform in `towel_yaw_range` (its
    hand-to-hand diagonal 85-105 degrees from the x axis), as LiftTowelHands (`tasks/cloth/base.py`'s
    `lay_between_hands`).

    **Success:** folded along a diagonal: for one of the napkin's two diagonal folds, the particles it pairs
    (`cloth.diagonal_fold_pairs`: each particle with its mirror image across the diagonal, opposite corners
    together) lie, on average, at most `fold_tol` from each other seen from above (`cloth.fold_distance(...,
    top_down=True)`, as FoldTowelInHalf: the layers' thickness is no fold error); the napkin lies on the table
    (no particle centre higher than `max_height` above it); both hands have let go (neither touches a particle,
    `ee.touches`); and both hands worked on it (`corners_held`, episode memory: at one control step the left
    hand and the right hand each held a napkin corner, `ee.holds`; one hand alone cannot hold two corners).

    **Level 2:** its Level-1 suite-mate LiftTowelHands takes the same napkin by the same two corners and
    lifts it straight up (2 stages, no placement tolerance, demos of ~110 steps in a 150-step horizon). Here the two hands
    do different things in sequence: one holds its corner on the table while the other lifts the opposite
    corner; the holding hand lets go and clears the way while the other carries its corner 24.7 cm in an arc
    over the napkin (the sheet hanging from the pinch drags the corner back through the fingers: the corner is
    aimed from where it hangs) and lays it onto the corner the first hand held. The 28 particle pairs of the
    diagonal fold count against a 2 cm mean top-down distance, and a well-folded napkin already uses most of
    it: its upper layer settles into the hollows between the lower layer's particles, half a cell off along both
    grid axes, 1.77 cm from its partners seen from above, so the placement error allowed on top of that is a
    few millimetres. Demos take ~175 steps of a 300-step horizon, 4 stages (pinch two corners, lift against the
    pin, carry over, lay and release): T = 10 log10 175 + 4 = 26.4 against LiftTowelHands'
    10 log10 111 + 2 = 22.5.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.28, 0.08, -0.2, 0.2)  # napkin centres plus its half diagonal (as LiftTowelHands)
    GRID = (8, 8)  # particles along each edge of the napkin
    PARAMS = FoldTowelTask.PARAMS + ("towel_x_range", "towel_y_range", "towel_yaw_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.hand_corners = side_corners(self.towel.layout)
        self.memory.flag("corners_held")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            lay_between_hands(self.towel, len(env_idx), x_range=self.towel_x_range, y_range=self.towel_y_range,
                              yaw_range=self.towel_yaw_range)

    def fold_pair_sets(self) -> list:
        """The two diagonal folds, each particle with its mirror image across the diagonal."""
        size = self.GRID[0]
        return [cloth.diagonal_fold_pairs(size), cloth.diagonal_fold_pairs(size, anti=True)]

    def _update_memory(self):
        latch_held_by_both(self, "corners_held", self.towel.corner_spheres())

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        obs["corners_held"] = info["corners_held"]
        if "state" in self.obs_mode:
            points = self.towel.positions()
            obs.update(towel_points=points.flatten(1), fold_error=info["fold_error"])
            for side, i in self.hand_corners.items():
                obs[f"{side}_tcp_to_corner"] = points[:, i] - self.ee.tcp(side).p
        return obs

    def evaluate(self):
        info = super().evaluate()
        info["corners_held"] = self.memory["corners_held"]
        info["success"] = info["success"] & info["corners_held"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        points = self.towel.positions()
        # each hand reaches the corner on its side; both held once; then the fold closes, laid down, let go
        reward = sum(1 - torch.tanh(5 * torch.linalg.norm(points[:, i] - self.ee.tcp(side).p, dim=1))
                     for side, i in self.hand_corners.items()) / 2
        reward += info["corners_held"].float()
        reward += 3 * info["corners_held"] * self.fold_progress(info)
        reward += (info["corners_held"] & info["folded"] & info["on_table"] & ~info["is_touching"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
