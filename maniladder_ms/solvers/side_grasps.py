"""LEAP hands' side grasps of upright containers (`bimanual.side_grasp` specs): how such a grasp is approached
from a ready pose, and the measured grasp that more than one task takes (PourGrainsHandToCup, PourWaterHand,
CupBeansHands)."""

from __future__ import annotations

import numpy as np

import torch

from maniladder_ms.solvers.bimanual import Grasp, side_grasp
from maniladder_ms.solvers.postures import LEAP_SYNERGIES

# the approach: the hand goes LINE_UP_ABOVE over its line-up point (the ready poses are there), LINE_UP_DISTANCE
# out from the grasp along the palm normal, takes the grasp's "approach" synergy over SIDE_PRESHAPE_STEPS, comes
# down to the line-up point and moves in
LINE_UP_DISTANCE = 0.1
LINE_UP_ABOVE = 0.1
# "preshape" swings the thumb under the palm before the descent: open, it hangs ~11 cm below the TCP and met the
# table at the line-up; swung for 5 steps only, PourGrainsHandToCup's glass then pivoted 30-45 deg in the carry
SIDE_PRESHAPE_STEPS = 20

# The left hand's grasp of a glass or cup (PourGrainsHandToCup's pourer, CupBeansHands' holder): palm normal -y,
# level, the finger row upright with the thumb low (for the left Panda joint 7 stays >= 0.8 rad from its limits
# over the reach, carry and roll; the right Panda's joint 7 would sit at 2.88 of its 2.90 rad limit), "preshape"
# on the way in; LEAP "power"'s fingers with the thumb joints beyond its base only slightly bent ("power"'s 0.6 /
# 0.8 / 0.8 pushed the standing glass over by ~30 deg while closing)
LEFT_THUMB_LOW_GRASP = dict(yaw=-np.pi / 2, pitch=0.0, up=-1.0, height=0.06, shift=0.04, inwards=0.0,
                            approach="preshape", close=LEAP_SYNERGIES["side_power"])


def lined_up_side_grasp(arm: str, ee: str, vessel_p: torch.Tensor, spec: dict) -> tuple[Grasp, torch.Tensor]:
    """(the `Grasp` of `arm` / `ee`, the palm normal) for the side grasp `spec` (`bimanual.side_grasp`) of an upright
    container standing at `vessel_p`, lined up `LINE_UP_DISTANCE` out from it along the palm normal."""
    p, q, normal = side_grasp(vessel_p, spec)
    return Grasp(arm, ee, p, q, -LINE_UP_DISTANCE * normal), normal
