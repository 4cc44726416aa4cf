"""Scripted solver of LiftRopeBimanual (tasks/rope/lift_rope_bimanual.py): each Panda grasps the second capsule
from the end on its side, then both rise together while moving apart, holding the rope nearly straight.

1. Each arm comes down over its capsule (the second from the end: a free end capsule turns in the closing
   fingers and slips out), top-down, fingers across the capsule, `GRASP_CLEARANCE` above its centre.
2. Both grippers close together.
3. Both glide up to `HOLD_HEIGHT` and apart to `HOLD_SPREAD` along the line between the grasps.
4. Hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rope.lift_rope_bimanual import LiftRopeBimanualEnv

GRASP_CLEARANCE = 0.004  # TCP this far above the capsule centre: finger tips off the table, free to close
HOLD_HEIGHT = 0.2  # the grasped end capsules end this high: the tips clear `lift_height` (15 cm)
HOLD_SPREAD = 0.33  # metres between the grasped capsule centres at the end (0.34 between them along the rope)


@register_solver("LiftRopeBimanual", control_modes=TCP_DELTA_MODES)
def solve_lift_rope_bimanual(env, seed: int) -> dict:
    """Each arm takes the second capsule from the end on its side top-down, fingers across the capsule; both close, then
    rise together while moving apart along the line between the ends, to hold the rope nearly straight."""
    with DrivenSolver.episode(env, seed) as s:
        task: LiftRopeBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        # the second capsule from each end: a free end capsule turns in the closing fingers and slips out
        first, last = task.rope.links[1], task.rope.links[-2]
        first_left = bool(first.pose.p[0, 1] >= last.pose.p[0, 1])  # one env: the solver's
        links = {"left": first if first_left else last, "right": last if first_left else first}
        grasps = []
        for side in task.SIDES:
            link = links[side]
            yaw = DrivenSolver.neutral_yaw(rope.segment_yaw(link.pose.q), np.pi)
            p = link.pose.p.clone()
            p[:, 2] = task.rope_config.radius + GRASP_CLEARANCE
            grasps.append(Grasp(f"{side}_arm", f"{side}_gripper", p, top_down_quat(yaw, n, device), above))
        reach(s, grasps)
        grasp_together(s, [g.ee for g in grasps])
        left, right = grasps
        middle = (left.p + right.p) / 2
        across = torch.nn.functional.normalize((left.p - right.p) * torch.tensor([1.0, 1.0, 0.0], device=device), dim=1)
        lift = torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=device) + middle * torch.tensor([1.0, 1.0, 0.0], device=device)
        ends = {"left": lift + across * HOLD_SPREAD / 2, "right": lift - across * HOLD_SPREAD / 2}
        glide(s, {g.arm: (g.p, ends[side], g.q) for side, g in zip(task.SIDES, grasps)})
        s.hold_until_success()
        return s.info
