"""Scripted solver of WrapRopeAroundPost (tasks/rope/wrap_rope_around_post.py): the Panda grasps the capsule next
to the free end and carries it round the post on a circle, low over the table, in the sense the rope already
winds, until the winding is one turn plus a margin; then lays it down and lets go.

1. Grasp the capsule `GRASP_FROM_END` from the free end top-down, fingers across it, and lift it to `CARRY_Z`.
2. Go to the circle of `CIRCLE_RADIUS` about the post on the grasp's bearing.
3. Carry it round, `ARC_STEP` of arc a control step, until the winding (anchor to grasp) is 1 + `MARGIN_TURNS`.
4. Lower it to the height it was grasped at, open, lift `RETREAT_HEIGHT` away.
5. Hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rope.wrap_rope_around_post import WrapRopeAroundPostEnv

GRASP_FROM_END = 1  # the solver grasps this capsule counted from the free end (0: the last)
GRASP_CLEARANCE = 0.004  # TCP this far above the capsule centre: finger tips off the table, free to close
CARRY_Z = 0.03  # TCP height while carrying: the fingertips 2 cm up, over the rope on the table
CIRCLE_RADIUS = 0.065  # the TCP's path about the post axis
ARC_STEP = 0.006  # metres of arc per control step
MARGIN_TURNS = 0.2  # carry the end this far past one full turn (the free tail settles back a little)
RETREAT_HEIGHT = 0.1  # the open gripper lifts this far off the laid rope


@register_solver("WrapRopeAroundPost", control_modes=TCP_DELTA_MODES)
def solve_wrap_rope_around_post(env, seed: int) -> dict:
    """Grasp the capsule next to the free end top-down, lift it to the carry height, go to the circle about
    the post on the end's bearing and carry it round in the sense the rope already winds (anchor to end)
    until the winding reaches one turn plus a margin; lower it, open, lift away."""
    with DrivenSolver.episode(env, seed) as s:
        task: WrapRopeAroundPostEnv = env.unwrapped
        device = task.device
        cfg = task.rope_config
        g = cfg.segments - 1 - GRASP_FROM_END
        link = task.rope.links[g]
        yaw = DrivenSolver.neutral_yaw(rope.segment_yaw(link.pose.q), np.pi)  # fingers across the capsule
        grasp = link.pose.p.clone()
        grasp[:, 2] = cfg.radius + GRASP_CLEARANCE
        s.pick("arm", "gripper", grasp, yaw, lift=CARRY_Z - cfg.radius)
        q = s.tcp("arm").q  # top-down, fingers across the capsule: kept all the way round
        post = task.post.pose.p[:, :2]
        # the winding so far, anchor to the grasped capsule, and the sense to continue it
        wound = rope.winding_number(task.rope.points()[:, :g + 2], post)
        sense = torch.where(wound >= 0, 1.0, -1.0)
        rel = s.tcp("arm").p[:, :2] - post
        start = torch.atan2(rel[:, 1], rel[:, 0])
        sweep = (sense * (1 + MARGIN_TURNS) - wound) * 2 * np.pi

        def on_circle(angle: torch.Tensor) -> torch.Tensor:
            xy = post + CIRCLE_RADIUS * torch.stack([torch.cos(angle), torch.sin(angle)], dim=1)
            return torch.cat([xy, torch.full((xy.shape[0], 1), CARRY_Z, device=device)], dim=1)

        s.move({"arm": (on_circle(start), q)}, max_steps=60, pos_tol=0.01)
        steps = int(np.ceil(float(sweep.abs().max()) * CIRCLE_RADIUS / ARC_STEP))
        for k in range(1, steps + 1):
            s.step({"arm": (on_circle(start + sweep * k / steps), q)})
        end = on_circle(start + sweep)
        s.move({"arm": (end, q)}, max_steps=15, pos_tol=0.005)
        lowered = end.clone()
        lowered[:, 2] = cfg.radius + GRASP_CLEARANCE  # back down to the height it was grasped at
        s.move({"arm": (lowered, q)}, max_steps=15, pos_tol=0.004)
        s.release("gripper")
        s.move({"arm": (s.above(lowered, RETREAT_HEIGHT), q)}, max_steps=20)
        s.hold_until_success()
        return s.info
