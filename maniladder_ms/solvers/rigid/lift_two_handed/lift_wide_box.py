"""Scripted solver of LiftWideBox (tasks/rigid/lift_two_handed/lift_wide_box.py): each gripper takes one end wall
top-down and both lift together.

1. Each arm comes down top-down over its end wall's grasp point (`lip_points`), fingers across the wall.
2. Both grippers close, then the arms rise LIFT together (`lift_together`).
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, lift_together
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rigid.lift_two_handed.lift_wide_box import LiftWideBoxEnv

LIFT = 0.15  # metres the grasp points rise: the box bottom ends 15 cm up, clear of the `lift_height` rule


@register_solver("LiftWideBox", control_modes=TCP_DELTA_MODES)
def solve_lift_wide_box(env, seed: int) -> dict:
    """Each arm grasps its end wall top-down, fingers across the wall; both close, then rise together."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftWideBoxEnv = env.unwrapped
        n, device = task.num_envs, task.device
        # fingers close along the box's long axis (across the end walls)
        q = top_down_quat(yaw_of(task.box.pose.q) - np.pi / 2, n, device)
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        grasps = [Grasp(f"{side}_arm", f"{side}_gripper", p, q, above) for side, p in task.lip_points().items()]
        lift_together(s, grasps, LIFT)
        s.hold_until_success()
        return s.info
