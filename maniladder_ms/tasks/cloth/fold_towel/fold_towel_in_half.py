"""FoldTowelInHalf (L2 deformable SG): fold a flat towel in half along its short axis, short edge onto short edge."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from .base import FoldTowelTask


@register_task("FoldTowelInHalf")
class FoldTowelInHalfEnv(FoldTowelTask):
    """**Task:** a rectangular towel lies flat on the table; fold it in half along its short axis: take
    one short edge, lift it and lay it onto the other short edge, so the towel lies doubled, half its
    length, and let go.

    **Randomisation:** the towel (`cloth.towel(10, 6)`: 10 x 6 particles 2.5 cm apart, a 25 x 15 cm
    sheet, particles of 10 mm radius so a folded layer rests on the sheet) lies flat, centred at x
    uniform in [-0.12, -0.02] (`TOWEL_X_LOW`, `TOWEL_X_SPAN`), y uniform in [-0.06, 0.06] (`TOWEL_Y`), its long
    axis turned by a yaw uniform in [-pi/4, pi/4) (`TOWEL_YAW_SPAN`).

    **Success:** folded along the short axis: the particles paired by that fold (`cloth.fold_pairs`
    across the long axis: each row with the row as far from the other short edge, the two short edges
    together) lie, on average, at most `fold_tol` from each other seen from above
    (`cloth.fold_distance(..., top_down=True)`: the two layers keep two particle radii between them,
    which is the cloth's thickness, not a fold error); the towel lies on the table (no particle centre
    higher than `max_height` above it: two layers, a wrinkle allowed, not held up or bunched); and the
    gripper has let go (touches no particle of the towel, `ee.touches`).

    **Level 2:** its Level-1 suite-mates move one part of the object once (FlattenTowelCorner lays
    back one corner of 21-28 particles over at most ~11 cm; DragRopeToGoal drags a rope flat; 150-step
    horizons, demos of 75-85 steps, 2 stages). Here half the sheet (30 of 60 particles) must turn over
    and land on the other half: two corners are pinched and carried ~22.5 cm each, one after the other
    (the second lies where the first carry dragged it, and the sheet slides under the carry), and all 30
    particle pairs count against a 2 cm mean (under the 2.5 cm particle spacing), with a 5.5 cm height
    cap; demos take ~200 steps of a 300-step horizon, 4 stages (pinch and carry, twice):
    T = 10 log10 200 + 4 = 27 against FlattenTowelCorner's 10 log10 84 + 2 = 21.
    """

    max_dense_reward = 5
    TASK_REGION = (-0.28, 0.14, -0.22, 0.22)  # towel centres plus the towel's half diagonal (14.6 cm) and a radius
    GRID = (10, 6)  # rows along the towel's long axis (its local x), columns along its short axis
    TOWEL_X_LOW, TOWEL_X_SPAN = -0.12, 0.1  # the towel's centre x: uniform in [low, low + span]
    TOWEL_Y = 0.06  # the towel's centre y: uniform in +-this
    TOWEL_YAW_SPAN = np.pi / 2  # the towel's yaw: uniform in [-span / 2, span / 2)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            yaw = (torch.rand(b) - 0.5) * self.TOWEL_YAW_SPAN
            xyz = torch.stack([torch.rand(b) * self.TOWEL_X_SPAN + self.TOWEL_X_LOW,
                               (torch.rand(b) * 2 - 1) * self.TOWEL_Y,
                               torch.full((b,), self.cloth_config.radius)], dim=1)
            self.towel.set_rest_shape(Pose.create_from_pq(xyz, yaw_quat(yaw)))

    def fold_pair_sets(self) -> list:
        """The short-axis fold: rows mirrored about the middle, the two short edges together."""
        return [cloth.fold_pairs(*self.GRID, axis=0)]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(towel_points=self.towel.positions().flatten(1), fold_error=info["fold_error"])
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        points = self.towel.positions()
        # reach the nearest short-edge corner, then bring the paired rows together, lay it down and let go
        corners = points[:, self.towel.layout.named["corners"]]
        reach = torch.linalg.norm(corners - self.ee.tcp().p[:, None], dim=-1).amin(dim=1)
        reward = 1 - torch.tanh(5 * reach)
        reward += 3 * self.fold_progress(info)
        reward += (info["folded"] & info["on_table"] & ~info["is_touching"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
