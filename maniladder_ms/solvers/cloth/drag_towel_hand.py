"""Scripted solver of DragTowelHand (tasks/cloth/drag_towel_hand.py): the LEAP hand scissor-pinches the towel's
leading corner and drags it closed loop until the towel's centroid is on the target.

1. Pinch: scissor-pinch the leading corner particle (`leading_corner`: index and middle straight down on either
   side of it, fingers along the towel's diagonal, swung together).
2. Drag: every step the TCP target moves `DRAG_SPEED` along the centroid's remaining way to the target, until the
   centroid is within half the goal radius (at most `DRAG_STEPS`).
3. Release: open the fingers and lift the hand `LIFT_AWAY`.
"""

from __future__ import annotations

import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.cloth.drag_towel_hand import DragTowelHandEnv

DRAG_SPEED = 0.006  # m a control step
DRAG_STEPS = 60  # at most this many drag steps
RELEASE_STEPS = 5  # the fingers open over this many steps
LIFT_AWAY = 0.06  # then the hand rises this far


def leading_corner(task: DragTowelHandEnv) -> torch.Tensor:
    """Per env, the corner particle furthest along the way from the towel's centroid to the target, [B]."""
    points = task.towel.positions()
    corners = torch.tensor(task.corner_ids, device=points.device)
    way = (task.target.pose.p - task.centroid())[:, :2]
    along = (points[:, corners, :2] * way[:, None]).sum(dim=-1)
    return corners[along.argmax(dim=1)]


@register_solver("DragTowelHand", control_modes=TCP_DELTA_MODES)
def solve_drag_towel_hand(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: DragTowelHandEnv = env.unwrapped
        points = task.towel.positions()
        corner = points[torch.arange(len(points), device=points.device), leading_corner(task)]
        tcp, q = DrivenSolver.corner_scissor_pose(corner, task.centroid(), task.cloth_config.radius)
        s.set_ee("hand", "scissor_open", steps=1)
        s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
        s.move({"arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
        s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        for _ in range(DRAG_STEPS):
            way = task.target.pose.p - task.centroid()
            way[:, 2] = 0
            length = torch.linalg.norm(way, dim=1, keepdim=True)
            if bool((length < task.goal_radius / 2).all()):
                break
            tcp = tcp + way * (DRAG_SPEED / length.clamp(min=DRAG_SPEED))
            s.step({"arm": (tcp, q)})
        s.set_ee("hand", "scissor_open", steps=RELEASE_STEPS)
        s.move({"arm": (s.above(tcp, LIFT_AWAY), q)}, max_steps=15, pos_tol=0.01)
        s.hold_until_success()
        return s.info
