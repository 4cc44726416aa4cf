"""Scripted solver of StretchRopeHands (tasks/rope/stretch_rope_hands.py): each LEAP hand pinches the second
capsule from the end on its side in the "scissor" pinch, then both rise together while moving apart.

1. Both hands open the index and middle fingers straight and spread (`scissor_open`) and come down over their
   capsules, fingers along the rope.
2. Both swing the two fingers together over `SCISSOR_RAMP_STEPS`.
3. Both glide up to `HOLD_HEIGHT` and apart to `HOLD_SPREAD`, `LIFT_STEP` a control step.
4. Hold still until success.
"""

from __future__ import annotations

import torch

from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.rope.stretch_rope_hands import StretchRopeHandsEnv

LIFT_STEP = 0.006  # metres a control step, as LiftRopeHand's lift: faster swings the rope out of the pinch
HOLD_HEIGHT = 0.15  # the pinched capsules end this high: the sagging rope and its hanging ends clear `lift_height` (5 cm)
HOLD_SPREAD = 0.335  # metres between the pinched capsule centres at the end (0.34 between them along the rope)


@register_solver("StretchRopeHands", control_modes=TCP_DELTA_MODES)
def solve_stretch_rope_hands(env, seed: int) -> dict:
    """Each hand takes the second capsule from the end on its side in the "scissor" pinch (fingers along the
    rope), both close together, then rise together while moving apart along the line between the ends."""
    with DrivenSolver.episode(env, seed) as s:
        task: StretchRopeHandsEnv = env.unwrapped
        device = task.device
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        first, last = task.rope.links[1], task.rope.links[-2]
        left_first = bool(task.first_is_left()[0])  # one env: the solver's
        links = {"left": first if left_first else last, "right": last if left_first else first}
        grasps, centres = [], {}
        for side in task.SIDES:
            link = links[side]
            centre = link.pose.p.clone()
            centre[:, 2] = task.rope_config.radius
            centres[side] = centre
            p, q = DrivenSolver.scissor_pose(centre, rope.segment_yaw(link.pose.q), mirror=side == "left")
            grasps.append(Grasp(f"{side}_arm", f"{side}_hand", p, q, above))
        for g in grasps:
            s.set_ee(g.ee, "scissor_open", steps=0)
        reach(s, grasps, preshape=None)
        grasp_together(s, [g.ee for g in grasps], "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        left, right = grasps
        middle = (left.p + right.p) / 2
        flat = torch.tensor([1.0, 1.0, 0.0], device=device)
        across = torch.nn.functional.normalize((left.p - right.p) * flat, dim=1)
        lift = torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=device) + middle * flat
        ends = {"left": lift + across * HOLD_SPREAD / 2, "right": lift - across * HOLD_SPREAD / 2}
        # each tcp moves as its capsule should
        glide(s, {g.arm: (g.p, g.p + ends[side] - centres[side], g.q) for side, g in zip(task.SIDES, grasps)},
              step_length=LIFT_STEP)
        s.hold_until_success()
        return s.info
