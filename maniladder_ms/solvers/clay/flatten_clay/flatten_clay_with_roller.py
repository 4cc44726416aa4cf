"""Scripted solver of FlattenClayWithRoller (tasks/clay/flatten_clay/flatten_clay_with_roller.py): both arms take
a handle of the rolling pin and lift it together; then passes, each lower than the last: lower the barrel onto
the middle of the clay that stands above the pass's height and roll it out to one end of that clay, lift, again
from the middle to the other end (the pressed clay is held by the table and spreads both ways instead of
sliding); until the clay is flat and wide enough or the next pass would not fit the horizon.

1. Both grippers open, come down onto the handles top-down (fingers closing along x, across the handle), close
   and wait `GRIP_STEPS`.
2. Lift the pin to `CARRY_Z`.
3. A pass at the next of `PASS_BOTTOMS`: for each end of the clay standing above that height, carry the barrel
   over its middle (`LIFT` above the pass), lower it pressing `PUSH` below, roll out to `OVERRUN` past that end,
   lift `LIFT`.
4. Repeat 3 until every height was passed and the clay is flat and spread with a margin (`HEIGHT_MARGIN`,
   `AREA_MARGIN`), or the next pass would not leave `FINAL_STEPS` of the horizon.
5. Lift the pin to `CARRY_Z`; hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.clay.flatten_clay.phases import flat_with_margin
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.clay.flatten_clay.flatten_clay_with_roller import SIDES, FlattenClayWithRollerEnv

CARRY_Z = 0.1  # the pin's axis this high while it is lifted off the table and at the end
CARRY_STEP = 0.01  # metres per control step of the pin through the air
HANDLE_APPROACH = 0.1  # the grippers come down onto the handles from this far above them
GRIP_STEPS = 10  # control steps the closed grippers settle on the handles before the lift
# Barrel bottom heights of the passes (m), the last repeated while the clay is not yet flat and wide enough
# with a margin: 2.8 / 2 cm leave 3 / 2 layers (2 stacked layers are 0.396 of the start height after
# springback, at the rule's edge), 1.4 / 1.2 cm press it towards a single layer, which spreads it (end heights
# 0.37-0.39; 2 cm repeated shoved the lump instead: 1.4-1.5x footprint).
PASS_BOTTOMS = (0.04, 0.028, 0.02, 0.014, 0.012)
PUSH = 0.003  # the grippers aim this far below where the barrel should be: the arms press as hard as they are off
OVERRUN = 0.012  # each roll ends this far (barrel axis) beyond the last clay standing above the pass's height
ROLL_STEP = 0.01  # metres per control step of a roll
LOWER_STEP = 0.006  # metres per control step while lowering onto or lifting off the clay
LIFT = 0.012  # the barrel rises this far above a pass's height between the halves of a pass
MAX_PASSES = 20
PASS_OVERHEAD_STEPS = 16  # a pass is estimated at twice its rolls' steps plus this many control steps
STANDING_ABOVE = 0.001  # a particle's top this far above a pass's barrel bottom counts as clay still to roll
REACH_X = (-0.3, 0.1)  # pin centre x range of the rolls (both arms reach it top-down)
HEIGHT_MARGIN, AREA_MARGIN = 0.02, 0.1  # passes go on until the clay is this far past both thresholds
FINAL_STEPS = 20  # control steps kept for the lift at the end and the settled success


@register_solver("FlattenClayWithRoller", control_modes=TCP_DELTA_MODES)
def solve_flatten_clay_with_roller(env, seed: int) -> dict:
    """Both arms take a handle top-down (fingers closing along x, across the handle) and lift the pin
    together; then passes, each lower than the last: lower the barrel onto the middle of the clay that
    stands above the pass's height and roll it out to one end of that clay, lift, again from the middle to
    the other end; until the clay is flat and wide enough or the next pass would not fit the horizon."""
    with DrivenSolver.episode(env, seed) as s:
        task: FlattenClayWithRollerEnv = env.unwrapped
        n, device = task.num_envs, task.device
        q = top_down_quat(torch.full((n,), np.pi / 2, device=device), n, device)  # fingers close along x
        handles = task.handle_centres()
        arms = {side: f"{side}_arm" for side in SIDES}
        for side in SIDES:
            s.release(f"{side}_gripper", steps=0)
        s.move({arms[side]: (s.above(p, HANDLE_APPROACH), q) for side, p in handles.items()}, max_steps=60)
        s.move({arms[side]: (p, q) for side, p in handles.items()}, max_steps=40, pos_tol=0.003)
        for side in SIDES:
            s.grip(True, f"{side}_gripper", steps=0)
        for _ in range(GRIP_STEPS):
            s.step()
        offsets = {side: s.tcp(arms[side]).p - task.pin.pose.p for side in SIDES}  # pin centre -> each TCP
        centre_y = task.clay.start.mean(dim=1)[:, 1]
        r, radius = task.pin_shape.barrel_radius, task.clay_config.radius

        def at(x: torch.Tensor, z: float | torch.Tensor) -> torch.Tensor:
            return torch.stack([x, centre_y, torch.as_tensor(z, device=device).expand(n)], dim=1)

        def glide_pin(a: torch.Tensor, b: torch.Tensor, step: float, push: float = 0.0):
            down = torch.tensor([0.0, 0.0, push], device=device)
            glide(s, {arms[side]: (a + offsets[side] - down, b + offsets[side] - down, q) for side in SIDES},
                  step_length=step, settle_steps=0)

        def stretch(bottom: float) -> tuple[torch.Tensor, torch.Tensor]:
            """x range of the particles whose tops stand above `bottom` (all of them if none)."""
            p = task.clay.positions()
            high = p[..., 2] + radius > bottom + STANDING_ABOVE
            high |= ~high.any(dim=1, keepdim=True)
            x = p[..., 0]
            return torch.where(high, x, torch.inf).amin(dim=1), torch.where(high, x, -torch.inf).amax(dim=1)

        pin = task.pin.pose.p.clone()
        glide_pin(pin, at(pin[:, 0], CARRY_Z), CARRY_STEP)
        pin = at(pin[:, 0], CARRY_Z)
        for k in range(MAX_PASSES):
            bottom = PASS_BOTTOMS[min(k, len(PASS_BOTTOMS) - 1)]
            low, high = stretch(bottom)
            mid = (low + high) / 2
            ends = [(high + OVERRUN).clamp(*REACH_X), (low - OVERRUN).clamp(*REACH_X)]
            cost = sum(int((e - mid).abs().max() / ROLL_STEP) for e in ends) * 2 + PASS_OVERHEAD_STEPS
            if int(s.info["elapsed_steps"].max()) + cost > task.task_spec.horizon - FINAL_STEPS:
                break
            for end in ends:
                above = at(mid, bottom + r + LIFT)
                glide_pin(pin, above, CARRY_STEP)
                glide_pin(above, at(mid, bottom + r), LOWER_STEP, PUSH)
                glide_pin(at(mid, bottom + r), at(end, bottom + r), ROLL_STEP, PUSH)
                pin = at(end, bottom + r + LIFT)
                glide_pin(at(end, bottom + r), pin, LOWER_STEP)
            info = s.info
            done = flat_with_margin(task, info, HEIGHT_MARGIN, AREA_MARGIN)
            if bool(done.all()) and k + 1 >= len(PASS_BOTTOMS):
                break
        glide_pin(pin, at(pin[:, 0], CARRY_Z), CARRY_STEP)
        s.hold_until_success()
        return s.info
