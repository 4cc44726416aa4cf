"""Scripted solver of SqueezeClayBimanual (tasks/clay/squeeze_clay_bimanual.py): both closed grippers, leaning out,
go down beside the block's two ends and move in together along y until the clay is `SQUEEZE_TO` of its start
width; they back off only if it stays narrow enough when it springs back.

1. Both grippers close and come down beside the block's ends (fingers closing along x, hands leaning out by
   `TILT`), `FINGER_HALF` + `GAP` off the clay, at `SQUEEZE_Z`.
2. Both move in by `SQUEEZE_STEP` a control step, aimed `AIM_PAST` past the clay's centre, until the clay is
   `SQUEEZE_TO` of its start width (at most `MAX_SQUEEZE_STEPS`).
3. If the clay is below `RELEASE_BELOW`, both back off `BACK_OFF` along y and rise `BACK_OFF_RISE`.
4. Hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.clay.squeeze_clay_bimanual import SIDES, SqueezeClayBimanualEnv

SQUEEZE_Z = 0.018  # TCP height while squeezing: the closed fingertips 1 cm above the table, over the block's side
FINGER_HALF = 0.01  # the closed fingers' half thickness along the squeeze
GAP = 0.02  # between the fingers and the clay before the squeeze
# The grippers' targets move in by SQUEEZE_STEP a control step towards each other, past the clay's
# centre by AIM_PAST of its start width (the arms push only as hard as their targets are far: aimed at
# the middle, they stall with the clay at 65%), until the clay is SQUEEZE_TO of its start width. Let go,
# it springs back by up to a yield distance (1.5 mm) per link across: 0.55 -> about 0.65 (the rule: 0.7)
AIM_PAST = 0.15  # share of the clay's start width
SQUEEZE_TO = 0.55  # share of the start width at which the squeeze stops
SQUEEZE_STEP = 0.004  # metres a control step, each gripper
MAX_SQUEEZE_STEPS = 40
RELEASE_BELOW = 0.6  # the grippers let go only below this share of the start width (else they keep squeezing)
BACK_OFF = 0.04  # the grippers back off this far along y from the squeezed clay
BACK_OFF_RISE = 0.05  # then rise this far
# The hands are 6 cm thick along the squeeze (fingers closing along x: a hand is 20 cm long across its
# closing axis, two of those along y would collide long before the clay is squeezed): each leans out by
# this angle about x, fingertips in, so the hands stay apart when the fingertips are 4 cm apart
TILT = 0.35


@register_solver("SqueezeClayBimanual", control_modes=TCP_DELTA_MODES)
def solve_squeeze_clay_bimanual(env, seed: int) -> dict:
    """Both grippers close, go down beside the clay's two ends (fingers closing along x, hands leaning out),
    move in together along y until the clay is 55% of its start width, and back off if it stays narrow enough
    when it springs back (else they keep it squeezed)."""
    with DrivenSolver.episode(env, seed) as s:
        task: SqueezeClayBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        closing = torch.tensor([[1.0, 0.0, 0.0]], device=device).repeat(n, 1)
        qs = {}
        for side, sign in SIDES.items():  # fingers down and leaning in towards the clay
            pointing = torch.tensor([[0.0, -sign * np.sin(TILT), -np.cos(TILT)]], dtype=torch.float32, device=device)
            qs[side] = tcp_quat(pointing.repeat(n, 1), closing)
        past = task.width(task.clay.start) * AIM_PAST
        starts, ends = {}, {}
        for side, face in task.side_faces().items():
            sign = SIDES[side]
            start, end = face.clone(), face.clone()
            start[:, 1] += sign * (FINGER_HALF + GAP)
            end[:, 1] = task.clay.start[..., 1].mean(dim=1) - sign * (past - FINGER_HALF)
            start[:, 2] = end[:, 2] = SQUEEZE_Z
            starts[side], ends[side] = start, end
        for side in SIDES:
            s.grip(True, f"{side}_gripper", steps=0)
        s.move({f"{side}_arm": (s.above(p, APPROACH_HEIGHT), qs[side]) for side, p in starts.items()}, max_steps=60,
               pos_tol=0.01)
        s.move({f"{side}_arm": (p, qs[side]) for side, p in starts.items()}, max_steps=30)
        length = max(float((ends[side] - starts[side]).norm(dim=1).max()) for side in SIDES)
        steps = max(1, round(length / SQUEEZE_STEP))
        for k in range(1, MAX_SQUEEZE_STEPS + 1):
            s.step({f"{side}_arm": (starts[side] + (ends[side] - starts[side]) * min(k / steps, 1.0), qs[side])
                    for side in SIDES})
            if bool((s.info["width_ratio"] <= SQUEEZE_TO).all()):
                break
        # let go only if the clay stays narrow enough when it springs back; else keep it squeezed (the
        # clay's outer columns can slip past the 2 cm wide fingers and stall the squeeze above 0.6)
        if bool((s.info["width_ratio"] <= RELEASE_BELOW).all()):
            backs = {side: s.tcp(f"{side}_arm").p + torch.tensor([0.0, SIDES[side] * BACK_OFF, 0.0], device=device)
                     for side in SIDES}
            s.move({f"{side}_arm": (backs[side], qs[side]) for side in SIDES}, max_steps=10, pos_tol=0.01)
            s.move({f"{side}_arm": (s.above(backs[side], BACK_OFF_RISE), qs[side]) for side in SIDES}, max_steps=10,
                   pos_tol=0.02)
        s.hold_until_success()
        return s.info
