"""Scripted solver of LiftBottleHand (tasks/rigid/lift_bottle_hand.py): a top-down power grasp with the LEAP hand
around the bottle's body below the shoulder, then a straight lift (TCP deltas).

1. Reach: the hand comes down over the bottle, its TCP `GRASP_OFFSET` from the body's grasp point (the bottle is
   round: any hand yaw does; yaw 0 points the fingers away from the robot).
2. Grasp: the fingers and thumb close around the body.
3. Lift: `LIFT_MARGIN` past the task's `lift_height`; hold until success.
"""

from __future__ import annotations

import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.lift_bottle_hand import LiftBottleHandEnv

# where the bottle's axis sits from the hand's tcp when the hand closes (world frame, hand yaw 0): 1 cm
# towards the fingertips, so the curling fingers meet it before the thumb pushes it away, and 1 cm to
# the index-finger side (+y), where it settles as the fingers close. With the tcp on the axis the thumb
# pushed the bottle over or it slipped out on 2 of 20 seeds
GRASP_OFFSET = (0.01, 0.01, 0.0)
LIFT_MARGIN = 0.05  # m the bottle is lifted beyond the task's lift_height


@register_solver("LiftBottleHand", control_modes=TCP_DELTA_MODES)
def solve_lift_bottle_hand(env, seed: int) -> dict:
    """Top-down power grasp around the body below the shoulder (the bottle is round: any hand yaw does;
    yaw 0 points the fingers away from the robot), then lift 15 cm."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftBottleHandEnv = env.unwrapped
        grasp_point = torch.tensor([0.0, 0.0, task.grasp_height], device=task.device)
        tcp = task.bottle.pose.p + grasp_point - torch.tensor(GRASP_OFFSET, device=task.device)
        s.pick("arm", "hand", tcp, yaw=0.0, lift=task.lift_height + LIFT_MARGIN)
        s.hold_until_success()
        return s.info
