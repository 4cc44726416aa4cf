"""Scripted solver of StampClay (tasks/clay/stamp_clay.py): grasp the stamp's handle top-down, carry the stamp over
the slab's centre (closed loop on the stamp's own position: it sits in the fingers a little off the TCP), lower it
straight down until its plate is `PRESS_DEPTH` in the clay, hold, and lift it straight up.

1. Grasp the post top-down, `GRASP_ABOVE_PLATE` over the plate, at any quarter turn of the square post.
2. Servo the stamp up to `CARRY_CLEARANCE` over the slab's top, then over the slab's centre (within `ALIGN_TOL`).
3. Press straight down: the TCP target sinks `PRESS_STEP` a control step towards `PRESS_AIM` below the slab's top
   until the plate is `PRESS_DEPTH` in the clay (at most `MAX_PRESS_STEPS`).
4. Hold `SETTLE_STEPS` at the full depth.
5. Lift the stamp `LIFT` straight up; hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.clay.stamp_clay import StampClayEnv

GRASP_ABOVE_PLATE = 0.016  # TCP height above the plate's top for the grasp: the fingertips (9 mm below the
# TCP) stop 7 mm above the plate, and come down onto it if the post slips up the fingers in the press
CARRY_CLEARANCE = 0.03  # the plate's bottom this far above the slab's top while carrying
ALIGN_TOL = 0.0015  # the stamp's centre this close (m) to the slab's centre before the press
PRESS_DEPTH = 0.0075  # the plate's bottom pressed this far below the slab's top (it overshoots by ~1 mm): the star's
# cells sink 5-8 mm; deeper (9.5-11 mm) the links drag the cells along the outline down past 5 mm too (IoU 0.51-0.65,
# against 0.67-0.77 here)
PRESS_AIM = 0.025  # the TCP aimed as if the plate's bottom went this far below the slab's top
PRESS_STEP = 0.002  # m per control step of that target on its way down
MAX_PRESS_STEPS = 60
SETTLE_STEPS = 8  # control steps at the full depth
LIFT = 0.05  # the stamp is lifted this far straight up off the clay
RISE_STEPS, RISE_TOL = 30, 0.01  # servo steps and tolerance (m) of the stamp's rise to the carry height
CENTRE_STEPS = 80  # servo steps of its move over the slab's centre


@register_solver("StampClay", control_modes=TCP_DELTA_MODES)
def solve_stamp_clay(env, seed: int) -> dict:
    """Grasp the handle top-down, carry the stamp over the slab's centre (closed loop on the stamp's own
    position: it sits in the fingers a little off the TCP), lower it straight down until its plate is
    `PRESS_DEPTH` in the clay, hold, and lift it straight up."""
    with DrivenSolver.episode(env, seed) as s:
        task: StampClayEnv = env.unwrapped
        n, device = task.num_envs, task.device
        shape = task.stamp_shape
        grasp = task.stamp.pose.p.clone()
        grasp[:, 2] = shape.plate + GRASP_ABOVE_PLATE
        yaw = DrivenSolver.neutral_yaw(yaw_of(task.stamp.pose.q), np.pi / 2)  # the square post: any quarter turn
        s.pick("arm", "gripper", grasp, yaw, lift=0.0)
        q = top_down_quat(yaw, n, device)
        top = task.slab_top()
        goal = torch.nn.functional.pad(task.slab_centre(), (0, 1))
        goal[:, 2] = top + CARRY_CLEARANCE

        def stamp_to(target: torch.Tensor, max_steps: int, tol: float):
            """Servo the stamp's origin to `target` [B, 3] by moving the TCP by the stamp's error every step."""
            for _ in range(max_steps):
                error = target - task.stamp.pose.p
                if bool((torch.linalg.norm(error, dim=1) < tol).all()):
                    return
                s.step({"arm": (s.tcp("arm").p + error, q)})

        up = task.stamp.pose.p.clone()
        up[:, 2] = goal[:, 2]
        stamp_to(up, RISE_STEPS, RISE_TOL)
        stamp_to(goal, CENTRE_STEPS, ALIGN_TOL)
        # straight down: the TCP keeps its xy and is aimed `PRESS_AIM` below the slab's top (the arm pushes
        # as hard as its target is far), until the plate is `PRESS_DEPTH` in the clay; then it stays there
        xy = s.tcp("arm").p[:, :2].clone()
        grip_z = s.tcp("arm").p[:, 2] - task.stamp.pose.p[:, 2]
        z = s.tcp("arm").p[:, 2].clone()
        pressed = torch.zeros(n, dtype=torch.bool, device=device)
        for _ in range(MAX_PRESS_STEPS):
            pressed |= task.stamp.pose.p[:, 2] <= top - PRESS_DEPTH
            z = torch.where(pressed, z, torch.maximum(z - PRESS_STEP, top - PRESS_AIM + grip_z))
            s.step({"arm": (torch.cat([xy, z[:, None]], dim=1), q)})
            if bool(pressed.all()):
                break
        for _ in range(SETTLE_STEPS):
            s.step({"arm": (torch.cat([xy, s.tcp("arm").p[:, 2:3]], dim=1), q)})
        lift = torch.cat([xy, (s.tcp("arm").p[:, 2] + LIFT)[:, None]], dim=1)
        s.move({"arm": (lift, q)}, max_steps=30, pos_tol=0.01)
        s.hold_until_success()
        return s.info
