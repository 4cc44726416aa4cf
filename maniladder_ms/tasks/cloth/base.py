"""What cloth tasks of different families share: the two arms' sides, the towel laid between two hands, each hand's
corner of it."""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg

SIDES = ("left", "right")  # the two arms, each taking the towel corner on its side
SIDE_Y_SIGN = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table
# the towel laid between the hands (`lay_between_hands`' defaults; a task passes its catalog params instead):
# its centre's x and y ranges (m), and its yaw range (deg): its hand-to-hand diagonal lies 85-105 degrees from the
# x axis. With the diagonal under 84 degrees the right hand's grasp yaw is past its Panda joint 7 limit (2.90 rad):
# on seeds 100-119 all 8 such towels left that arm 0.2 rad short of the grasp orientation and the demo ran past
# its horizon
BETWEEN_HANDS_X_RANGE, BETWEEN_HANDS_Y_RANGE = (-0.14, -0.06), (-0.03, 0.03)
BETWEEN_HANDS_YAW_RANGE = (40, 60)


def side_corners(layout: cloth.ClothLayout) -> dict[str, int]:
    """The particle index of each hand's corner: the corners furthest left (+y) and right at reset (the
    towel's yaw keeps them the same two: the corners on the diagonal x + y of its own grid)."""
    corners = layout.named["corners"]
    along = [float(layout.positions[i, 0] + layout.positions[i, 1]) for i in corners]
    return {"left": corners[int(np.argmax(along))], "right": corners[int(np.argmin(along))]}


def lay_between_hands(towel: cloth.Cloth, b: int, turn: float = 0.0, x_range=BETWEEN_HANDS_X_RANGE,
                      y_range=BETWEEN_HANDS_Y_RANGE, yaw_range=BETWEEN_HANDS_YAW_RANGE):
    """Lay `towel` flat for `b` envs being reset (in the env's torch device context), one corner towards each
    hand: centre x uniform in `x_range`, y in `y_range` (m), yaw uniform in `yaw_range` (deg) plus `turn` (rad; a
    half turn swaps the hands' corners: `side_corners` then names them the other way round)."""
    centre = torch.stack([uniform(b, x_range), uniform(b, y_range), torch.full((b,), towel.config.radius)], dim=1)
    yaw = uniform_deg(b, yaw_range) + turn
    towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))
