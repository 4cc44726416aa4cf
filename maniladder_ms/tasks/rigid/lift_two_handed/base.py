"""The LiftTwoHanded family's base (LiftWideBox, LiftBasketHands; PingPongTransport and LiftPotToStove build their
rule on its lift): both end effectors hold one object and lift it level.

The family base `LiftTwoHandedTask` holds the rule, `evaluate`, once for every embodiment; the task classes
build their object (`self.item`, whose pose origin is its bottom centre); their solvers are in
`maniladder_ms/solvers/rigid/lift_two_handed/`.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.geometry import tilt

SIDE_SIGNS = {"left": 1, "right": -1}  # the left end effector takes the object's +y side (handle, end wall)


class LiftTwoHandedTask(ManiLadderEnv):
    """Family base (registers no task). **Success:** the object's bottom is at least `lift_height` above the
    table, it is tilted by less than `max_tilt` (its up axis from the world's), and each end effector
    (left and right) holds it (`ee.holds`).
    """

    PARAMS = ("lift_height", "max_tilt")
    SIDES = ("left", "right")
    item = None  # set by the task's `_load_scene`: the object lifted, its pose origin at its bottom centre

    def evaluate(self):
        height = self.item.pose.p[:, 2]
        angle = tilt(self.item)
        info = {f"{side}_grasped": self.ee.holds(self.item, side) for side in self.SIDES}
        info.update(is_lifted=height >= self.lift_height, is_level=angle < np.deg2rad(self.max_tilt),
                    height=height, tilt=angle)
        held = torch.stack([info[f"{side}_grasped"] for side in self.SIDES]).all(dim=0)
        info["success"] = info["is_lifted"] & info["is_level"] & held
        return info

    def two_hand_obs(self, info: dict, points: dict, point_name: str, state: dict) -> dict:
        """The observation the family's two-arm tasks share: each TCP's pose, each end effector's hold and the
        memory `carried`; in state obs modes also `state` (the task's own entries, in order) and each TCP's
        offset to its grasp point (`points`: side -> world point; keys `<side>_tcp_to_<point_name>`)."""
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in self.SIDES}
        obs.update({f"{side}_grasped": info[f"{side}_grasped"] for side in self.SIDES}, carried=info["carried"])
        if "state" in self.obs_mode:
            obs.update(state)
            obs.update({f"{side}_tcp_to_{point_name}": points[side] - self.ee.tcp(side).p for side in self.SIDES})
        return obs

    def reach_and_hold_reward(self, points: dict, info: dict) -> torch.Tensor:
        """(num_envs,) in [0, 2]: per side, half for the TCP's nearness to its grasp point (`points`: side ->
        world point), half for holding the object."""
        reward = torch.zeros(self.num_envs, device=self.device)
        for side in self.SIDES:
            reach = torch.linalg.norm(points[side] - self.ee.tcp(side).p, dim=1)
            reward += 0.5 * (1 - torch.tanh(5 * reach)) + 0.5 * info[f"{side}_grasped"]
        return reward
