"""What the rope tasks share: a rope built in `_load_scene` (`RopeTask`) and, for the two-arm tasks whose rope
lies across the table between the arms, its layout, which arm holds which end, the observation and the reward's
shape (`RopeBetweenArmsTask`). The rope's physics and metrics are `maniladder_ms.deformables.rope`."""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import rope
from maniladder_ms.layout import uniform, uniform_deg


class RopeTask:
    """Mixin for a task env (before `ManiLadderEnv` in its bases) with one rope `self.rope` built from its
    `rope_config` in `_load_scene` (`rope_anchored`: its first capsule fixed in place, a cable tied down at
    one end), and `grasp_segment`: the capsule a grasp near the middle takes."""

    rope_config = rope.RopeConfig()
    rope_anchored = False

    @property
    def grasp_segment(self) -> int:
        return self.rope_config.segments // 2

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.rope = rope.build_rope(self.scene, "rope", self.rope_config, fix_first_end=self.rope_anchored)

    def lay_wavy(self, b: int) -> torch.Tensor:
        """Lay the rope flat in a gentle S (`rope.wavy_turns`, amplitude up to `rope_max_amp` deg), its first capsule
        heading uniform in `rope_yaw_range` (deg), the mean of its capsule centres uniform in `rope_x_range` x
        `rope_y_range` (the single-arm rope tasks' catalog params), drawn in that order on the current device;
        returns the capsule centres [b, segments, 3]."""
        turns = rope.wavy_turns(b, self.rope_config.segments, np.deg2rad(self.rope_max_amp))
        heading = uniform_deg(b, self.rope_yaw_range)
        middle = torch.stack([uniform(b, self.rope_x_range), uniform(b, self.rope_y_range)], dim=1)
        return self.rope.lay_flat(middle, heading, turns)


class RopeBetweenArmsTask(RopeTask):
    """`RopeTask` for two-arm tasks whose rope lies across the table between the arms: the rope
    (`rope_config`) lies flat along y in a gentle S (`rope.wavy_turns`, amp uniform up to `rope_max_amp`), the
    mean of its capsule centres at x uniform in `rope_x_range`, y uniform in `rope_y_range`, its first capsule
    heading within +-`rope_max_yaw` (uniform) of +y or of -y: the catalog params `ROPE_LAYOUT_PARAMS`, which
    the task's `PARAMS` include. The task defines `end_points()` ({"left", "right"} -> [B, 3],
    where each arm takes the rope) and the param `end_capsules`; `end_holds()` says whether each end effector
    holds (`ee.holds`) one of the `end_capsules` outermost capsules at the end on its side, which the task
    reports as `left_grasped` / `right_grasped` in its info."""

    SIDES = ("left", "right")
    # the rope's layout ranges (catalog params, degrees for angles): read by `lay_rope`
    ROPE_LAYOUT_PARAMS = ("rope_x_range", "rope_y_range", "rope_max_yaw", "rope_max_amp")

    def first_is_left(self) -> torch.Tensor:
        """(B,) bool: the rope's first capsule lies on the left (+y) arm's side."""
        return self.rope.links[0].pose.p[:, 1] >= self.rope.links[-1].pose.p[:, 1]

    def side_points(self, k: int) -> dict[str, torch.Tensor]:
        """Centres of the k-th capsule from each end (0: the end capsules), keyed by the arm on whose side that
        end lies, [B, 3] each."""
        first, last = self.rope.links[k].pose.p, self.rope.links[-1 - k].pose.p
        left_first = self.first_is_left()[:, None]
        return {"left": torch.where(left_first, first, last), "right": torch.where(left_first, last, first)}

    def end_links(self, count: int) -> tuple[list, list]:
        """The `count` capsules at each end of the rope, outermost first: (first end, last end)."""
        links = self.rope.links
        return links[:count], links[::-1][:count]

    def end_holds(self) -> dict[str, torch.Tensor]:
        """{"left", "right"} -> (B,) bool: that end effector holds one of the `end_capsules` outermost
        capsules at the rope's end on its side."""
        first, last = self.end_links(self.end_capsules)
        left_first = self.first_is_left()
        held = {}
        for side, own_first in zip(self.SIDES, (left_first, ~left_first)):
            if own_first.all():  # every sub-scene's end on this side is the same one: ask about it alone
                held[side] = self.ee.holds(first, side)
            elif not own_first.any():
                held[side] = self.ee.holds(last, side)
            else:
                held[side] = torch.where(own_first, self.ee.holds(first, side), self.ee.holds(last, side))
        return held

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self.place_by_rope(self.lay_rope(len(env_idx)))

    def place_by_rope(self, centres: torch.Tensor):
        """Place what a task sets relative to where its rope lies (capsule centres of the sub-scenes being reset,
        [b, segments, 3]; torch's default device is the env's); the family places nothing."""

    def lay_rope(self, b: int) -> torch.Tensor:
        """Lay the rope of the `b` sub-scenes being reset (on torch's default device) as the class docstring
        says; returns its capsule centres, [b, segments, 3] (`rope.Rope.lay_flat`)."""
        turns = rope.wavy_turns(b, self.rope_config.segments, np.deg2rad(self.rope_max_amp))
        heading = (np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(self.rope_max_yaw)
                   + torch.where(torch.rand(b) < 0.5, 0.0, np.pi))
        middle = torch.stack([uniform(b, self.rope_x_range), uniform(b, self.rope_y_range)], dim=1)
        return self.rope.lay_flat(middle, heading, turns)

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in self.SIDES}
        obs.update(left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            obs["rope_points"] = self.rope.points().flatten(1)
            for side, p in self.end_points().items():
                obs[f"{side}_tcp_to_end"] = p - self.ee.tcp(side).p
        return obs

    def _two_arm_reward(self, info: dict, *progress: torch.Tensor) -> torch.Tensor:
        """Dense reward: each arm's reach to its end point (1 each), each arm's grasp (1 each), then with both
        grasped each of `progress` (fractions of the goal, clamped to [0, 1]); `max_dense_reward` on success."""
        ends = self.end_points()
        reward = sum(1 - torch.tanh(5 * torch.linalg.norm(p - self.ee.tcp(side).p, dim=1))
                     for side, p in ends.items())
        reward = reward + info["left_grasped"].float() + info["right_grasped"].float()
        both = info["left_grasped"] & info["right_grasped"]
        for fraction in progress:
            reward = reward + fraction.clamp(0, 1) * both
        reward[info["success"]] = self.max_dense_reward
        return reward
