"""Scripted solver of HangTowelOnBar (tasks/cloth/hang_towel/hang_towel_on_bar.py): both grippers pinch the towel's
corners nearest the bar, carry them over the bar together and let go with the towel hanging on both sides.

1. Pinch: each arm lines up over the corner on its side of the towel's edge nearest the bar (`corner_grasp`:
   top-down, fingers opened to 4 cm closing along the corner's diagonal, as SpreadTowelBimanual, the TCP
   `PINCH_OUTSET` outwards of the corner and `PINCH_ABOVE` over it), both close together.
2. Check: both corners lifted `PINCH_CHECK_LIFT`; one not held is pinched again where it lies (`pinch_checked`).
3. Lift: rise together until the TCPs are `CARRY_ABOVE_BAR` over the bar's top.
4. Carry: over the bar to `BEYOND_BAR` past its axis (the towel slides up and over the rod).
5. Lower: to `RELEASE_ABOVE_BAR` over the bar's top; read whether both corners are hooked on the inner fingers
   (`both_hooked`, fingers still closed).
6. Release: open fully; where hooked, glide `HOOK_PULL` towards the rod and rise quickly first.
7. Back off along the corners' outward diagonals (along +x where hooked) and rise.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide, grasp_together, reach
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.cloth.base import SIDE_Y_SIGN, SIDES
from maniladder_ms.tasks.cloth.hang_towel.hang_towel_on_bar import CORNER, HangTowelOnBarEnv

FINGER_GAP_CMD = 0.2  # normalised gripper command: fingers 4 cm apart, around the corner particle only
# the pinch's TCP lies this far outwards of the corner particle along the towel's diagonal: the inner finger,
# touching first, pulls the corner out of its cell, so after the lift it presses fewer of the corner's neighbours
# (the "hook" that keeps the corner on the opened finger). Seeds 100-149: 42/50 at 6 mm, 39/50 at 0
PINCH_OUTSET = 0.006
# and this far above the particle's centre: seeds 100-149 46/50 at 3 mm, 44/50 at 0 and at 5 mm
PINCH_ABOVE = 0.003
# closed-loop pinches: both corners lifted this high, then each checked (ee.holds); a missed or slipped one is
# pinched again from this high above where it lies now, at most this many times
PINCH_CHECK_LIFT, REPINCH_APPROACH, REPINCH_TRIES = 0.03, 0.05, 2
# the descent onto a corner stalls where a finger lands on the corner's neighbours: waiting longer moves nothing
MOVE_IN_STEPS = 25
CARRY_ABOVE_BAR = 0.04  # TCP height above the bar's top while the corners go over it
BEYOND_BAR = 0.11  # the corners are carried this far past the bar's axis: about half the towel's length
RELEASE_ABOVE_BAR = 0.01  # then lowered until the TCPs are this high above the bar's top (the hand bodies, turned
# along the corners' diagonals and reaching 3.7 cm above the TCP, clear the towel on the rod), and let go
LIFT_STEP, CARRY_STEP, LOWER_STEP = 0.01, 0.008, 0.006  # metres per control step
RELEASE_STEPS = 8
# where both inner fingers are hooked at the release pose (`both_hooked`: each touches both of its corner's
# neighbours; on opening, the towel pulls each corner onto its inner finger's face and, the pull being more
# horizontal than 45 degrees at friction 1, it stays there through the back-off and the rise), the opened hands
# first glide `HOOK_PULL` towards the rod (rising `HOOK_PULL_RISE`): the corners, dragged along, come over the
# rod's far flank, where their pull turns downwards; then rise `HOOK_LIFT` quickly (`HOOK_LIFT_STEP` a step), so
# the corners slip off the fingertips, and back off along +x. It saves 2 of the 4 both-hooked seeds of 100-149
HOOK_PULL, HOOK_PULL_RISE, HOOK_LIFT, HOOK_LIFT_STEP = 0.09, 0.02, 0.06, 0.02
# after letting go, the opened hands back off horizontally along the corner's outward diagonal (the fingers'
# open gap: they slide past the corner particle without pushing it), then rise: rising first lifted the towel's
# far edge, lying over a finger after the release, off the bar again (seed 106)
BACK_OFF, RISE = 0.08, 0.05


def corner_grasp(task: HangTowelOnBarEnv, side: str, approach: float) -> Grasp:
    """Top-down pinch of the corner particle on `side` where it lies now: fingers opened to `FINGER_GAP_CMD`,
    closing along the corner's diagonal (the towel's yaw read from its corners), the TCP `PINCH_OUTSET` outwards
    of the corner along that diagonal and `PINCH_ABOVE` over its centre, lined up `approach` above."""
    n, device = task.num_envs, task.device
    points = task.towel.positions()
    corners = task.towel.layout.named["corners"]
    towel_axis = points[:, corners[2]] - points[:, corners[0]]
    towel_yaw = torch.atan2(towel_axis[:, 1], towel_axis[:, 0])
    diagonal = float(np.arctan2(SIDE_Y_SIGN[side], 1.0))  # the corner's outward diagonal, local
    yaw = DrivenSolver.neutral_yaw(towel_yaw + diagonal + np.pi / 2, np.pi)
    corner = task.corner_particles()[side].pose.p
    outwards = corner - points.mean(dim=1)
    outwards[:, 2] = 0
    p = corner + torch.nn.functional.normalize(outwards, dim=1) * PINCH_OUTSET
    p[:, 2] += PINCH_ABOVE
    return Grasp(f"{side}_arm", f"{side}_gripper", p, top_down_quat(yaw, n, device),
                 torch.tensor([0.0, 0.0, approach], device=device))


def pinch_checked(s: DrivenSolver, task: HangTowelOnBarEnv, grasps: dict) -> dict:
    """After both grippers closed on their corners: lift them `PINCH_CHECK_LIFT` and check each pinch
    (`ee.holds` its corner particle); where one missed or slipped, that gripper (only) opens, lines up
    `REPINCH_APPROACH` above the corner where it lies now, pinches it again and lifts it back, up to
    `REPINCH_TRIES` times. The held corner waits in the air. Returns the grasps, their `p` where the TCPs
    now are."""
    device = task.device
    check = torch.tensor([0.0, 0.0, PINCH_CHECK_LIFT], device=device)
    glide(s, {g.arm: (g.p, g.p + check, g.q) for g in grasps.values()}, step_length=LIFT_STEP, settle_steps=5)
    grasps = {side: Grasp(g.arm, g.ee, g.p + check, g.q, g.approach) for side, g in grasps.items()}
    for _ in range(REPINCH_TRIES):
        missed = {side: ~task.ee.holds(task.corner_particles()[side], side) for side in grasps}
        missed = {side: m for side, m in missed.items() if bool(m.any())}
        if not missed:
            break
        for side, m in missed.items():
            cmd = s.ee_cmd[grasps[side].ee].clone()
            cmd[m] = FINGER_GAP_CMD
            s.set_ee(grasps[side].ee, cmd, steps=0)
        new = {side: corner_grasp(task, side, REPINCH_APPROACH) for side in missed}

        def where(side, p, q):  # the new target where this side missed, else the held pose
            m = missed[side].unsqueeze(1)
            return torch.where(m, p, grasps[side].p), torch.where(m, q, grasps[side].q)

        s.move({grasps[side].arm: where(side, grasps[side].p + check, grasps[side].q) for side in missed},
               max_steps=8)
        s.move({g.arm: where(side, *g.lined_up) for side, g in new.items()}, max_steps=25, pos_tol=0.01)
        s.move({g.arm: where(side, g.p, g.q) for side, g in new.items()}, max_steps=MOVE_IN_STEPS, pos_tol=0.003)
        for side, m in missed.items():
            cmd = s.ee_cmd[grasps[side].ee].clone()
            cmd[m] = -1.0
            s.set_ee(grasps[side].ee, cmd, steps=0)
        for _ in range(8):
            s.step()
        glide(s, {g.arm: (where(side, g.p, g.q)[0], where(side, g.p + check, g.q)[0], where(side, g.p, g.q)[1])
                  for side, g in new.items()}, step_length=LIFT_STEP, settle_steps=3)
        for side, g in new.items():
            p, q = where(side, g.p + check, g.q)
            grasps[side] = Grasp(g.arm, g.ee, p, q, g.approach)
    return grasps


def both_hooked(task: HangTowelOnBarEnv) -> torch.Tensor:
    """[B] bool: each gripper touches both edge neighbours of its corner particle (the one along the towel's
    rows and the one along its edge): its inner finger sits inside the corner's cell."""
    hooked = torch.ones(task.num_envs, dtype=torch.bool, device=task.device)
    for side, k in CORNER.items():
        for i in task.towel.layout.neighbours(task.towel.layout.named["corners"][k]):
            hooked &= task.ee.touches(task.towel.spheres[i], side)
    return hooked


@register_solver("HangTowelOnBar", control_modes=TCP_DELTA_MODES)
def solve_hang_towel_on_bar(env, seed: int) -> dict:
    """The phases of the module docstring, both arms in lock-step."""
    with DrivenSolver.episode(env, seed) as s:
        task: HangTowelOnBarEnv = env.unwrapped
        n, device = task.num_envs, task.device
        bar = task.bar.pose.p
        grasps = {side: corner_grasp(task, side, APPROACH_HEIGHT) for side in SIDES}
        for g in grasps.values():
            s.set_ee(g.ee, [FINGER_GAP_CMD], steps=0)
        reach(s, list(grasps.values()), move_in_steps=MOVE_IN_STEPS)
        grasp_together(s, [g.ee for g in grasps.values()])
        grasps = pinch_checked(s, task, grasps)
        grasps = list(grasps.values())
        top = task.bar_height + CARRY_ABOVE_BAR
        high = {g.arm: torch.cat([g.p[:, :2], torch.full((n, 1), top, device=device)], dim=1) for g in grasps}
        glide(s, {g.arm: (g.p, high[g.arm], g.q) for g in grasps}, step_length=LIFT_STEP, settle_steps=5)
        over = {}
        for g in grasps:
            over[g.arm] = high[g.arm].clone()
            over[g.arm][:, 0] = bar[:, 0] + BEYOND_BAR
        glide(s, {g.arm: (high[g.arm], over[g.arm], g.q) for g in grasps}, step_length=CARRY_STEP, settle_steps=5)
        low = {arm: p - torch.tensor([0.0, 0.0, CARRY_ABOVE_BAR - RELEASE_ABOVE_BAR], device=device)
               for arm, p in over.items()}
        glide(s, {g.arm: (over[g.arm], low[g.arm], g.q) for g in grasps}, step_length=LOWER_STEP, settle_steps=5)
        hooked = both_hooked(task)  # read with the fingers still closed
        for g in grasps:
            s.set_ee(g.ee, [1.0], steps=0)
        for _ in range(RELEASE_STEPS):
            s.step()
        up = torch.tensor([0.0, 0.0, RISE], device=device)
        points = task.towel.positions()
        away = {}
        for side in SIDES:
            outwards = task.corner_particles()[side].pose.p - points.mean(dim=1)
            outwards[:, 2] = 0
            away[f"{side}_arm"] = torch.nn.functional.normalize(outwards, dim=1) * BACK_OFF
        if bool(hooked.any()):
            h = hooked.unsqueeze(1).float()
            pull = torch.tensor([-HOOK_PULL, 0.0, HOOK_PULL_RISE], device=device) * h
            lift = torch.tensor([0.0, 0.0, HOOK_LIFT], device=device) * h
            glide(s, {g.arm: (low[g.arm], low[g.arm] + pull, g.q) for g in grasps}, step_length=LOWER_STEP,
                  settle_steps=0)
            glide(s, {g.arm: (low[g.arm] + pull, low[g.arm] + pull + lift, g.q) for g in grasps},
                  step_length=HOOK_LIFT_STEP, settle_steps=0)
            low = {arm: p + pull + lift for arm, p in low.items()}
            along_x = torch.tensor([BACK_OFF, 0.0, 0.0], device=device)
            away = {arm: torch.where(hooked.unsqueeze(1), along_x, a) for arm, a in away.items()}
        glide(s, {g.arm: (low[g.arm], low[g.arm] + away[g.arm], g.q) for g in grasps}, step_length=LOWER_STEP,
              settle_steps=0)
        glide(s, {g.arm: (low[g.arm] + away[g.arm], low[g.arm] + away[g.arm] + up, g.q) for g in grasps},
              step_length=LIFT_STEP, settle_steps=5)
        s.hold_until_success()
        return s.info
