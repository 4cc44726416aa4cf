"""Scripted solver of FoldTowelHand (tasks/cloth/fold_towel/fold_towel_hand.py): the LEAP hand scissor-pinches a
corner of the far short edge and lays it onto its partner corner of the near edge in an arc over the fold line;
the sheet hanging from the corner drags the rest of the far half over with it.

1. Pinch: scissor-pinch the far edge's corner (`far_corner`; as DragTowelHand's corner pinch, the fingers along
   the sheet's diagonal, `DrivenSolver.corner_scissor_pose`).
2. Carry: lift `LIFT`, then an arc `ARC_HEIGHT` high over the middle of the way to `HOVER` above the partner
   corner, in `CARRY_STEPS`.
3. Lay: lower the corner to `RELEASE_ABOVE` over its partner, aimed from where the corner hangs in the pinch
   (read again `LAY_CORRECTIONS` times).
4. Release: open the fingers and rise `RISE`.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import follow_paths, glide
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.cloth.fold_towel.fold_towel_hand import FoldTowelHandEnv

# the carry is FoldNapkinHands' (the same corner scissor pinch carried over a sheet), set once: seeds 100-149 49/50
LIFT = 0.04  # the corner first rises this high
ARC_HEIGHT = 0.12  # then passes over the middle of its way this high (about the towel's half length)
CARRY_STEPS = 45  # control steps of the arc (FoldNapkinHands: 50 for a 24.7 cm carry; 22.5 cm here)
HOVER = 0.04  # the arc ends this high above the partner corner
RELEASE_ABOVE = 0.02  # the corner is let go this high above its partner: one layer's thickness
LAY_STEP = 0.004  # metres a control step while laying the corner down
LAY_CORRECTIONS = 2  # times the lay target is read again from where the corner hangs in the pinch
RELEASE_STEPS = 8  # the fingers open over this many steps
RISE = 0.06  # then the hand rises this far


def far_corner(task: FoldTowelHandEnv) -> tuple[int, int, int]:
    """The corner of the short edge further from the robot (larger x), its diagonal neighbour inside the sheet
    and its partner corner on the near edge (particle ids; env 0's towel decides, as the CPU backend runs one)."""
    rows, cols = task.GRID
    index = np.arange(rows * cols).reshape(rows, cols)
    points = task.towel.positions()[0]
    far_row = 0 if float(points[index[0], 0].mean()) > float(points[index[-1], 0].mean()) else rows - 1
    near_row, inward = rows - 1 - far_row, (1 if far_row == 0 else -1)
    return int(index[far_row, 0]), int(index[far_row + inward, 1]), int(index[near_row, 0])


@register_solver("FoldTowelHand", control_modes=TCP_DELTA_MODES)
def solve_fold_towel_hand(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: FoldTowelHandEnv = env.unwrapped
        up = lambda h: torch.tensor([0.0, 0.0, h], device=task.device)  # noqa: E731
        corner, inner, partner = far_corner(task)
        points = task.towel.positions()
        tcp, q = DrivenSolver.corner_scissor_pose(points[:, corner], points[:, inner], task.cloth_config.radius)
        s.set_ee("hand", "scissor_open", steps=1)
        s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
        s.move({"arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
        s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        lifted = tcp + up(LIFT)
        glide(s, {"arm": (s.tcp().p.clone(), lifted, q)}, settle_steps=0)
        # the TCP keeps its offset to the pinched particle: it goes where the corner should go
        points = task.towel.positions()
        hover = s.tcp().p + (points[:, partner] + up(HOVER) - points[:, corner])

        def arc(t: float) -> torch.Tensor:
            return lifted + (hover - lifted) * t + up(ARC_HEIGHT - LIFT) * 4 * t * (1 - t)

        follow_paths(s, {"arm": (arc, q)}, CARRY_STEPS)
        for _ in range(LAY_CORRECTIONS):
            points = task.towel.positions()
            lay = s.tcp().p + (points[:, partner] + up(RELEASE_ABOVE) - points[:, corner])
            glide(s, {"arm": (s.tcp().p.clone(), lay, q)}, step_length=LAY_STEP, settle_steps=5)
        s.set_ee("hand", "scissor_open", steps=RELEASE_STEPS)
        tcp = s.tcp().p.clone()
        glide(s, {"arm": (tcp, tcp + up(RISE), q)}, settle_steps=0)
        s.hold_until_success()
        return s.info
