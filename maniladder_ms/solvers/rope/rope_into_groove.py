"""Scripted solver of RopeIntoGroove (tasks/rope/rope_into_groove.py): each Panda grasps the second capsule from
the end on its side; in lock-step they lift the rope nearly straight, carry it over the groove turned onto its
axis, lower it until the held capsules are just above the walls and let go.

1. Both grippers open half way (`GRASP_OPENING`: clear of the groove's wall) and come down over their capsules,
   top-down, fingers across the capsule; both close together.
2. Both glide up to `CARRY_HEIGHT` and apart to `SPREAD`.
3. Both glide over the groove's centre, each gripper turning the short way onto its axis.
4. Both glide down until the held capsules are `RELEASE_ABOVE_TOP` above the walls' top (`SET_DOWN_STEP`), open,
   wait `RELEASE_WAIT_STEPS`.
5. Both rise `RETREAT_FRACTION` of `APPROACH_HEIGHT`; hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import RELEASE_WAIT_STEPS, SET_DOWN_STEP, Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rope.rope_into_groove import RopeIntoGrooveEnv

GRASP_CLEARANCE = 0.004  # TCP this far above the capsule centre: finger tips off the table, free to close
GRASP_OPENING = 0.0  # normalised gripper command for the approach: 3 cm between the finger pads
CARRY_HEIGHT = 0.1  # the grasped capsules' height while the rope is carried over the groove
SPREAD = 0.33  # metres between the grasped capsule centres (0.34 between them along the rope): nearly straight
RELEASE_ABOVE_TOP = 0.012  # the grasped capsules' centres this far above the walls' top when let go
RETREAT_FRACTION = 0.5  # the open grippers rise this share of APPROACH_HEIGHT off the laid rope
RETREAT_SETTLE_STEPS = 5  # control steps held at the top of the retreat, the rope settling in the groove


@register_solver("RopeIntoGroove", control_modes=TCP_DELTA_MODES)
def solve_rope_into_groove(env, seed: int) -> dict:
    """Each arm takes the second capsule from the end on its side top-down, fingers across the capsule; both
    close, rise together while moving apart to hold the rope nearly straight, carry it over the groove's axis
    (turning the grippers onto it), lower it until the held capsules are just above the walls' top (the
    sagging middle already in the groove), open both and rise."""
    with DrivenSolver.episode(env, seed) as s:
        task: RopeIntoGrooveEnv = env.unwrapped
        n, device = task.num_envs, task.device
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        radius = task.rope_config.radius
        ends = task.end_points()
        grasps = []
        first_left = bool(task.first_is_left()[0])  # one env: the solver's
        links = {"left": task.rope.links[1 if first_left else -2], "right": task.rope.links[-2 if first_left else 1]}
        yaws = {side: DrivenSolver.neutral_yaw(rope.segment_yaw(links[side].pose.q), np.pi) for side in task.SIDES}
        for side in task.SIDES:
            p = ends[side].clone()
            p[:, 2] = radius + GRASP_CLEARANCE
            grasps.append(Grasp(f"{side}_arm", f"{side}_gripper", p, top_down_quat(yaws[side], n, device), above))
        for g in grasps:  # half open: the fingers stay clear of the groove's wall when the rope lies near it
            s.set_ee(g.ee, [GRASP_OPENING], steps=0)
        reach(s, grasps)
        grasp_together(s, [g.ee for g in grasps])
        left, right = grasps
        flat = torch.tensor([1.0, 1.0, 0.0], device=device)
        up = torch.tensor([0.0, 0.0, CARRY_HEIGHT + GRASP_CLEARANCE], device=device)
        middle = (left.p + right.p) / 2 * flat
        across = torch.nn.functional.normalize((left.p - right.p) * flat, dim=1)
        lifted = {"left": middle + up + across * SPREAD / 2, "right": middle + up - across * SPREAD / 2}
        glide(s, {g.arm: (g.p, lifted[side], g.q) for side, g in zip(task.SIDES, grasps)})
        # over the groove: its axis points to +y (the left arm's side) within 20 degrees
        axis = task.groove.axis()
        along = torch.stack([torch.cos(axis), torch.sin(axis), torch.zeros_like(axis)], dim=1)
        # each gripper turns the short way onto the axis (the fingers are symmetric: a half turn is no turn)
        qs = {side: top_down_quat(yaws[side] + DrivenSolver.neutral_yaw(axis - yaws[side], np.pi), n, device)
              for side in task.SIDES}
        centre = task.groove.pose.p * flat
        over = {"left": centre + up + along * SPREAD / 2, "right": centre + up - along * SPREAD / 2}
        glide(s, {g.arm: (lifted[side], over[side], qs[side]) for side, g in zip(task.SIDES, grasps)})
        down = torch.tensor([0.0, 0.0, task.groove.top + RELEASE_ABOVE_TOP + GRASP_CLEARANCE], device=device)
        low = {side: centre + down + along * (SPREAD / 2 if side == "left" else -SPREAD / 2) for side in task.SIDES}
        glide(s, {g.arm: (over[side], low[side], qs[side]) for side, g in zip(task.SIDES, grasps)},
              step_length=SET_DOWN_STEP)
        for g in grasps:
            s.release(g.ee, steps=0)
        for _ in range(RELEASE_WAIT_STEPS):
            s.step()
        glide(s, {g.arm: (low[side], low[side] + above * RETREAT_FRACTION, qs[side]) for side, g in zip(task.SIDES, grasps)},
              settle_steps=RETREAT_SETTLE_STEPS)
        s.hold_until_success()
        return s.info
