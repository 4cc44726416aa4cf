"""Scripted solver of FoldShirt (tasks/cloth/fold_shirt/fold_shirt.py): each Panda folds the sleeve on its side in,
one after the other, by its cuff corners, then both carry the hem's two corners together over the body onto the
collar.

1. Sleeves, one arm at a time (left arm: the shirt's right sleeve, on its side; folded at once the two hands met
   over the body, 7.5 cm apart, and stopped each other): the arm pinches its sleeve's cuff corner at the collar end
   from above, fingers opened to 4 cm (`FINGER_GAP_CMD`) closing across the corner's diagonal (as
   SpreadTowelBimanual's corner pinch), and carries it (`_carry_together`): lift `LIFT`, over the middle of the way
   `SLEEVE_ARC_HEIGHT` high, down onto the corner's folded place (`shirt.fold`'s, with the body as it lies now:
   read again above it), open fully, wait, rise; then the cuff's hem-end corner likewise if the sleeve is not in yet;
   then the arm parks out on its side (`PARK`).
2. Hem: both arms pinch the hem's two corners, both hands closing along the same diagonal of the shirt (the +y
   corner across its own diagonal, the -y corner along its own, the inner finger clear of the diagonal
   neighbour): parallel, the hands keep 8.7 cm between their axes; each closing across its own corner's diagonal,
   the hands crossed over the body and stopped each other 1.5-2.6 cm short of the corners (seed 100). They carry
   the corners together, `HEM_ARC_HEIGHT` over the middle of the way, onto the collar's corners, the hem laid
   `HEM_LAY_HEIGHT` up (on the folded sleeves), open fully, wait, rise.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import shirt
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.cloth.base import SIDES
from maniladder_ms.tasks.cloth.fold_shirt.fold_shirt import FoldShirtEnv

FINGER_GAP_CMD = 0.2  # normalised gripper command: fingers 4 cm apart, around the corner particle only
GRASP_ABOVE = 0.003  # the TCP this far above a particle's centre: the pads pinch its sides
LIFT = 0.05  # a corner is first lifted this high
SLEEVE_ARC_HEIGHT = 0.08  # a cuff corner is carried over the middle of its ~10 cm way this high
HEM_ARC_HEIGHT = 0.12  # the hem's corners over the middle of their 17.5 cm way (about the fold's half length)
CARRY_STEP = 0.008  # metres per control step along a carry
SLEEVE_LAY_HEIGHT = 0.035  # TCP height where a cuff corner is let go: one layer up on the body, plus a little
HEM_LAY_HEIGHT = 0.055  # where the hem's corners are let go: on the folded sleeves (two layers up)
# the fingers open all the way to let go: opened to 4 cm only, the left gripper rose with the hem's corner between
# its fingers (seed 102, 1 of seeds 100-102)
RELEASE_CMD = 1.0
RELEASE_STEPS = 8  # control steps the opened fingers wait before rising
RISE = 0.06  # the arms rise this far after letting go
ARM_SLEEVE = {"left": "right", "right": "left"}  # each arm folds the sleeve on its side (the shirt's right: +y)
PARK = {"left": (-0.25, 0.28, 0.15), "right": (-0.25, -0.28, 0.15)}  # where an arm waits, out of the other's way


def _corner(task: FoldShirtEnv, corner: int, dx: float, dy: float) -> tuple[int, int]:
    """(`corner`, its diagonal neighbour): the particle at rest offset (`dx`, `dy`) spacings from it."""
    rest = task.shirt.layout.positions
    target = rest[corner] + np.array([dx, dy, 0.0]) * shirt.spacing_of(task.shirt.layout)
    return corner, int(np.argmin(np.linalg.norm(rest - target, axis=1)))


def _cuff_corner(task: FoldShirtEnv, sleeve: str, collar_end: bool) -> tuple[int, int]:
    cuff = shirt.cuff_ids(task.shirt.layout, sleeve)  # hem to collar
    inward = -shirt.SIDE_SIGN[sleeve]
    return _corner(task, cuff[-1], -1, inward) if collar_end else _corner(task, cuff[0], 1, inward)


def _hem_corner(task: FoldShirtEnv, arm: str) -> tuple[int, int]:
    """The hem corner on the arm's side (left arm: +y) with its diagonal neighbour."""
    hem = sorted(task.shirt.layout.named["hem"], key=lambda i: task.shirt.layout.positions[i, 1])
    return _corner(task, hem[-1], 1, -1) if arm == "left" else _corner(task, hem[0], 1, 1)


def _carry_together(s: DrivenSolver, task: FoldShirtEnv, picks: dict, arc_height: float, lay_height: float):
    """Each arm in `picks` (side -> (particle, its diagonal neighbour, goal(): its goal [B, 2] read now, whether
    the fingers close along the line to the neighbour instead of across it)) pinches its particle, lifts it, carries it over the middle of its way `arc_height` high to above its goal (read again
    there), lowers it to `lay_height`, lets go (fingers to 4 cm), waits and rises."""
    n, device = task.num_envs, task.device
    above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
    points = task.shirt.positions()
    grasps = {}
    for side, (i, inner, _, along) in picks.items():
        diagonal = points[:, inner, :2] - points[:, i, :2]
        yaw = torch.atan2(diagonal[:, 1], diagonal[:, 0]) + (0.0 if along else np.pi / 2)
        q = top_down_quat(DrivenSolver.neutral_yaw(yaw, np.pi), n, device)
        grasps[side] = Grasp(f"{side}_arm", f"{side}_gripper", points[:, i].clone(), q, above)
    for g in grasps.values():
        s.set_ee(g.ee, [FINGER_GAP_CMD], steps=0)
    s.move({g.arm: g.lined_up for g in grasps.values()}, max_steps=60)
    points = task.shirt.positions()  # aim at where the particles lie now
    for side, (i, _, _, _) in picks.items():
        grasps[side].p = points[:, i] + torch.tensor([0.0, 0.0, GRASP_ABOVE], device=device)
    reach(s, list(grasps.values()), line_up_steps=20)
    grasp_together(s, [g.ee for g in grasps.values()])
    up = torch.tensor([0.0, 0.0, LIFT], device=device)
    glide(s, {g.arm: (g.p, g.p + up, g.q) for g in grasps.values()}, settle_steps=5)

    def goal_at(side: str, height: float) -> torch.Tensor:
        xy = picks[side][2]()
        return torch.cat([xy, torch.full((n, 1), height, device=device)], dim=1)

    middle = {side: (grasps[side].p + goal_at(side, 0.0)) / 2 for side in picks}
    for m in middle.values():
        m[:, 2] = arc_height
    glide(s, {g.arm: (g.p + up, middle[side], g.q) for side, g in grasps.items()}, step_length=CARRY_STEP,
          settle_steps=0)
    glide(s, {g.arm: (middle[side], goal_at(side, lay_height + LIFT), g.q) for side, g in grasps.items()},
          step_length=CARRY_STEP, settle_steps=5)
    glide(s, {g.arm: (goal_at(side, lay_height + LIFT), goal_at(side, lay_height), g.q) for side, g in grasps.items()},
          step_length=CARRY_STEP, settle_steps=5)
    for g in grasps.values():
        s.set_ee(g.ee, [RELEASE_CMD], steps=0)
    for _ in range(RELEASE_STEPS):
        s.step()
    rise = torch.tensor([0.0, 0.0, RISE], device=device)
    glide(s, {g.arm: (s.tcp(g.arm).p, s.tcp(g.arm).p + rise, g.q) for g in grasps.values()}, settle_steps=5)


@register_solver("FoldShirt", control_modes=TCP_DELTA_MODES)
def solve_fold_shirt(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: FoldShirtEnv = env.unwrapped
        layout = task.shirt.layout
        folded, _ = shirt.fold(layout)

        def folded_place(i: int):
            return lambda: shirt.local_place(task.shirt.positions(), layout, folded[[i], :2])[:, 0]

        def collar_place(i: int):
            # the collar particle of the hem corner's column: where the hem corner goes
            column = {h: c for h, c in shirt.hem_collar_pairs(layout)}
            return lambda: shirt.flat_place(task.shirt.positions(), layout, [column[i]])[:, 0]

        for arm in SIDES:
            sleeve = ARM_SLEEVE[arm]
            for collar_end in (True, False):
                if not collar_end and bool(task.evaluate()[f"{sleeve}_sleeve_in"][0]):
                    break
                i, inner = _cuff_corner(task, sleeve, collar_end)
                _carry_together(s, task, {arm: (i, inner, folded_place(i), False)}, SLEEVE_ARC_HEIGHT,
                                SLEEVE_LAY_HEIGHT)
            park = torch.tensor(PARK[arm], device=task.device).expand(task.num_envs, 3)
            s.move({f"{arm}_arm": (park, s.tcp(f"{arm}_arm").q)}, max_steps=40, pos_tol=0.02)
        picks = {}
        for arm in SIDES:
            i, inner = _hem_corner(task, arm)
            picks[arm] = (i, inner, collar_place(i), arm == "right")
        _carry_together(s, task, picks, HEM_ARC_HEIGHT, HEM_LAY_HEIGHT)
        s.hold_until_success()
        return s.info
