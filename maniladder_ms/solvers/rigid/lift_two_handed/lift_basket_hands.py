"""Scripted solver of LiftBasketHands (tasks/rigid/lift_two_handed/lift_basket_hands.py): each LEAP hand takes its
handle from above and both lift together.

1. Each hand comes down top-down over its handle bar (`handle_centres`), fingers over the outside of the bar, the
   thumb in the gap behind it.
2. Both hands close together, then the arms rise LIFT in step (`lift_together`).
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, lift_together
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.lift_two_handed.base import SIDE_SIGNS
from maniladder_ms.tasks.rigid.lift_two_handed.lift_basket_hands import LiftBasketHandsEnv

APPROACH = 0.06  # metres above the grasp the hands come down from
BAR_CLEARANCE = 0.006  # the TCP this far above the handle bar's centre
LIFT = 0.15  # metres the hands rise together


@register_solver("LiftBasketHands", control_modes=TCP_DELTA_MODES)
def solve_lift_basket_hands(env, seed: int) -> dict:
    """Each hand takes its handle from above (fingers over the outside of the bar, thumb in the gap
    behind it), both close together and lift LIFT in step."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftBasketHandsEnv = env.unwrapped
        n = task.num_envs
        basket_yaw = yaw_of(task.basket.pose.q)
        handles = task.handle_centres()
        up = torch.tensor([0.0, 0.0, APPROACH], device=task.device)
        above_bar = torch.tensor([0, 0, BAR_CLEARANCE], device=task.device)
        grasps = [Grasp(f"{side}_arm", f"{side}_hand", handles[side] + above_bar,
                        top_down_quat(basket_yaw + sign * np.pi / 2, n, device=task.device), up)
                  for side, sign in SIDE_SIGNS.items()]
        lift_together(s, grasps, LIFT)
        s.hold_until_success()
        return s.info
