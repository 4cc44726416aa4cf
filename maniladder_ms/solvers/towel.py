"""Towel phases shared by the solvers of cloth tasks of different families: two LEAP hands pinching the towel's
side corners (`tasks/cloth/base.py`'s `side_corners`)."""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import cloth
from maniladder_ms.solvers.bimanual import Grasp, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS

# the top-down hand yaw each arm reaches the towel's corners with: +-45 degrees from it, either arm stops 2-5 cm
# short of a corner at 14.6 cm height (seed 100), so the towel lies with a diagonal along y
ARM_YAW = {"left": np.pi / 2, "right": -np.pi / 2}


def pinch_side_corners(s: DrivenSolver, towel: cloth.Cloth, hand_corners: dict[str, int]) -> dict[str, Grasp]:
    """Each LEAP hand scissor-pinches the corner particle `hand_corners[side]` of the flat `towel` (as
    DragTowelHand's corner pinch: fingers along the sheet's diagonal): both line up, move in and close
    together. Returns each side's Grasp (its TCP pose at the pinch)."""
    points = towel.positions()
    centroid = points.mean(dim=1)
    above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=points.device)
    grasps = {}
    for side, i in hand_corners.items():
        p, q = DrivenSolver.corner_scissor_pose(points[:, i], centroid, towel.config.radius,
                                                mirror=side == "left", around=ARM_YAW[side])
        grasps[side] = Grasp(f"{side}_arm", f"{side}_hand", p, q, above)
    for g in grasps.values():
        s.set_ee(g.ee, "scissor_open", steps=0)
    reach(s, list(grasps.values()), preshape=None)
    grasp_together(s, [g.ee for g in grasps.values()], "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
    return grasps
