"""What cloth tasks of different families share: the two arms' sides, the towel laid between two hands, each hand's
corner of it."""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import cloth
from maniladder_ms.geometry import yaw_quat

SIDES = ("left", "right")  # the two arms, each taking the towel corner on its side
SIDE_Y_SIGN = {"left": 1.0, "right": -1.0}  # sign of y on each arm's side of the table
# the towel laid between the hands: its centre x uniform in [low, low + span], y likewise
BETWEEN_HANDS_X_LOW, BETWEEN_HANDS_X_SPAN = -0.14, 0.08
BETWEEN_HANDS_Y_LOW, BETWEEN_HANDS_Y_SPAN = -0.03, 0.06
# and its yaw: its hand-to-hand diagonal lies 85-105 degrees from the x axis. With the diagonal under 84 degrees
# the right hand's grasp yaw is past its Panda joint 7 limit (2.90 rad): on seeds 100-119 all 8 such towels left
# that arm 0.2 rad short of the grasp orientation and the demo ran past its horizon
TOWEL_YAW_MIN, TOWEL_YAW_MAX = np.pi / 4 - np.pi / 36, np.pi / 4 + np.pi / 12


def side_corners(layout: cloth.ClothLayout) -> dict[str, int]:
    """The particle index of each hand's corner: the corners furthest left (+y) and right at reset (the
    towel's yaw keeps them the same two: the corners on the diagonal x + y of its own grid)."""
    corners = layout.named["corners"]
    along = [float(layout.positions[i, 0] + layout.positions[i, 1]) for i in corners]
    return {"left": corners[int(np.argmax(along))], "right": corners[int(np.argmin(along))]}


def lay_between_hands(towel: cloth.Cloth, b: int, turn: float = 0.0):
    """Lay `towel` flat for `b` envs being reset (in the env's torch device context), one corner towards each
    hand: centre x uniform in [-0.14, -0.06], y in [-0.03, 0.03], yaw uniform in [TOWEL_YAW_MIN, TOWEL_YAW_MAX]
    plus `turn` (a half turn swaps the hands' corners: `side_corners` then names them the other way round)."""
    centre = torch.stack([torch.rand(b) * BETWEEN_HANDS_X_SPAN + BETWEEN_HANDS_X_LOW,
                          torch.rand(b) * BETWEEN_HANDS_Y_SPAN + BETWEEN_HANDS_Y_LOW,
                          torch.full((b,), towel.config.radius)], dim=1)
    yaw = TOWEL_YAW_MIN + torch.rand(b) * (TOWEL_YAW_MAX - TOWEL_YAW_MIN) + turn
    towel.set_rest_shape(Pose.create_from_pq(centre, yaw_quat(yaw)))
