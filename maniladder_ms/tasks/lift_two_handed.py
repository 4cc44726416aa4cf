"""The LiftTwoHanded family's rule (LiftWideBox, LiftBasketHands): both end effectors hold one object and lift
it level.

The family base `LiftTwoHandedTask` holds the rule, `evaluate`, once for every embodiment; the task classes
build their object (`self.item`, whose pose origin is its bottom centre) and keep their solvers.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.objects.basket import tilt


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
