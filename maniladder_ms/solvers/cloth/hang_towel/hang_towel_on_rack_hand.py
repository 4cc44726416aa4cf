"""Scripted solver of HangTowelOnRackHand (tasks/cloth/hang_towel/hang_towel_on_rack_hand.py): the LEAP hand
pinches the towel at the middle of a side edge so it hangs as a flag, and lays its ridge along the rack's rod.

1. Pinch: the gather (`gather_open`, the open scissor spread wide, the tips `EDGE_PRESS` into the sheet) at the
   middle of the side edge whose outward direction is within 90 degrees of yaw 0, `EDGE_INSET` in from the edge
   particles (`EDGE_INSET_LAST` on the last column), fingers along the columns pointing out of the sheet; close.
2. Lift: to `EDGE_CARRY_ABOVE` over the bar's top, then turn the hand to `HOLD_YAW`: the towel hangs as a flag
   across the bar, its ridge (rows 4-5) vertical under the pinch.
3. Carry: over the bar's axis, the pinch half the ridge's length along the rod; wait `SWING_STEPS`.
4. Lower: until the flag's foot is `LAY_GAP` over the rod's top.
5. Lay: the pinch goes down and along the rod at 45 degrees (`LAY_STEP` each way a step), laying the ridge on the
   rod column by column, shifted across the bar with the imbalance (`rebalance`).
6. Balance: up to `LAY_BALANCE_STEPS` more steps of `rebalance` until `BALANCED_STEPS` in a row within
   `BALANCE_TOL`.
7. Release: open (`gather_open`) and rise `RISE`.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.cloth.hang_towel.base import ROWS
from maniladder_ms.tasks.cloth.hang_towel.hang_towel_on_rack_hand import HangTowelOnRackHandEnv

# the gather pinch: the open scissor spread to +-GATHER_SPREAD rad (LEAP side joints), the tips pressed into the
# sheet, swung together: the tips drag the particles between them together by friction and squeeze them (seeds
# 100-104, tips 1 cm into the sheet's middle: 5/5 lifted the towel; a spread of 0.25 or 0.6 rad: 0-1/5)
GATHER_SPREAD = 0.5
# the edge pinch: the gather at the middle of a side edge (between rows 4 and 5 of its outer column, EDGE_INSET in
# from the edge particles, the tips EDGE_PRESS into the sheet); carried EDGE_CARRY_ABOVE over the bar's top, laid
# from LAY_GAP over the rod, LAY_STEP along and LAY_STEP down a step
EDGE_INSET, EDGE_PRESS, EDGE_CARRY_ABOVE, LAY_GAP, LAY_STEP = 0.0125, 0.005, 0.22, 0.015, 0.004
# the last column's pinch (the hand mirrored against the first's: not the same grasp) EDGE_INSET_LAST in from the
# edge: the 25 last-column seeds of 100-149 19/25 at EDGE_INSET -> 22/25
EDGE_INSET_LAST = 0.006
HOLD_YAW = np.deg2rad(89.0)  # the hand's yaw while carrying (the pinched pair across the bar)
LIFT_STEP, CARRY_STEP, LOWER_STEP = 0.012, 0.01, 0.008  # metres per control step
SWING_STEPS = 10  # wait over the bar for the carried towel to stop swinging
# with the pinch on the bar's top, shift it across the bar (GAIN metres per step per unit of imbalance, at most
# MAX_SHIFT) until the towel hangs evenly (near and far fractions within BALANCE_TOL, BALANCED_STEPS in a row)
GAIN, MAX_SHIFT, BALANCE_TOL, BALANCED_STEPS = 0.005, 0.04, 0.04, 3
LAY_BALANCE_STEPS = 30  # balancing steps after the lay (balancing only during the lay: dev seeds 0-19 14/20, 16/20)
RELEASE_STEPS, RISE = 8, 0.08


def gather_open() -> np.ndarray:
    """The LEAP joint targets of the open scissor with the index and middle fingers spread to +-GATHER_SPREAD."""
    q = LEAP_SYNERGIES["scissor_open"].copy()
    q[0], q[4] = -GATHER_SPREAD, GATHER_SPREAD
    return q


def rebalance(task: HangTowelOnRackHandEnv, shift: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The drape's imbalance now (hanging fraction near minus far) and `shift` (the pinch across the bar, m)
    moved GAIN times it towards the lighter side, within MAX_SHIFT."""
    sides = task.hanging()
    imbalance = sides[:, 0] - sides[:, 1]
    return (shift + GAIN * imbalance).clamp(-MAX_SHIFT, MAX_SHIFT), imbalance


@register_solver("HangTowelOnRackHand", control_modes=TCP_DELTA_MODES)
def solve_hang_towel_on_rack_hand(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: HangTowelOnRackHandEnv = env.unwrapped
        n, device = task.num_envs, task.device
        points = task.towel.positions()
        cols = task.towel.layout.positions.shape[0] // ROWS
        grid = points.reshape(n, ROWS, cols, 3)
        rows_axis = points[:, cols] - points[:, 0]  # along the towel's rows (its local x)
        towel_yaw = torch.atan2(rows_axis[:, 1], rows_axis[:, 0])
        first = towel_yaw >= 0  # pinch column 0 (its outward direction towel_yaw - 90 degrees), else the last
        sign = torch.where(first, 1.0, -1.0)  # sign of y from the pinched edge to the other one, after the turn
        edge = torch.where(first[:, None], grid[:, 4:6, 0].mean(dim=1), grid[:, 4:6, -1].mean(dim=1))
        inner = torch.where(first[:, None], grid[:, 4:6, 1].mean(dim=1), grid[:, 4:6, -2].mean(dim=1))
        inset = torch.where(first, EDGE_INSET, EDGE_INSET_LAST)[:, None]
        centre = edge + torch.nn.functional.normalize(inner - edge, dim=1) * inset
        centre[:, 2] = task.cloth_config.radius - EDGE_PRESS
        tcp, q = DrivenSolver.scissor_pose(centre, towel_yaw - sign * torch.pi / 2)
        s.set_ee("hand", gather_open(), steps=1)
        s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
        s.move({"arm": (tcp, q)}, max_steps=30, pos_tol=0.003)
        s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        bar = task.bar.pose.p
        hand_yaw = -sign * HOLD_YAW
        top = task.bar_height + task.cloth_config.radius  # a particle's centre resting on the bar's top

        def tcp_for(x, y, z):  # the TCP pose placing the pinch at (x, y, z)
            z = torch.as_tensor(z, device=device, dtype=torch.float32).expand(n)
            return DrivenSolver.scissor_pose(torch.stack([x, y, z], dim=1), hand_yaw)

        half = (cols - 1) / 2 * task.cloth_config.spacing  # half the ridge's length
        y_start, y_end = bar[:, 1] + sign * half, bar[:, 1] - sign * half
        high, q2 = tcp_for(edge[:, 0], edge[:, 1], top + EDGE_CARRY_ABOVE)
        glide(s, {"arm": (s.tcp().p.clone(), high, q)}, step_length=LIFT_STEP, settle_steps=5)
        s.move({"arm": (high, q2)}, max_steps=80, pos_tol=0.01, rot_tol=0.05)
        over, _ = tcp_for(bar[:, 0], y_start, top + EDGE_CARRY_ABOVE)
        glide(s, {"arm": (s.tcp().p.clone(), over, q2)}, step_length=CARRY_STEP, settle_steps=10)
        for _ in range(SWING_STEPS):
            s.step()
        foot = task.towel.positions()[..., 2].amin(dim=1)  # the flag's lowest particle
        z = top + EDGE_CARRY_ABOVE - (foot - top - LAY_GAP)
        start, _ = tcp_for(bar[:, 0], y_start, z)
        glide(s, {"arm": (over, start, q2)}, step_length=LOWER_STEP, settle_steps=3)
        shift = torch.zeros(n, device=device)
        y = y_start.clone()
        while True:
            shift, _ = rebalance(task, shift)
            y = y - sign * LAY_STEP
            y = torch.where((y - y_end) * sign <= 0, y_end, y)  # stopped at the ridge's far end
            z = (z - LAY_STEP).clamp(min=top)
            low, _ = tcp_for(bar[:, 0] + shift, y, z)
            s.step({"arm": (low, q2)})
            if bool((y == y_end).all()) and bool((z <= top).all()):
                break
        for _ in range(5):
            s.step({"arm": (low, q2)})
        streak = 0
        for _ in range(LAY_BALANCE_STEPS):
            shift, imbalance = rebalance(task, shift)  # near side heavier: the pinch moves to the far side
            streak = streak + 1 if bool((imbalance.abs() < BALANCE_TOL).all()) else 0
            if streak >= BALANCED_STEPS:
                break
            low, _ = tcp_for(bar[:, 0] + shift, y_end, top)
            s.step({"arm": (low, q2)})
        s.set_ee("hand", gather_open(), steps=RELEASE_STEPS)
        glide(s, {"arm": (low, s.above(low, RISE), q2)}, step_length=LIFT_STEP, settle_steps=5)
        s.hold_until_success()
        return s.info
