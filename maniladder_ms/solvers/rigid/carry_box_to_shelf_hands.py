"""Scripted solver of CarryBoxToShelfHands (tasks/rigid/carry_box_to_shelf_hands.py): both LEAP hands press their
palms on the carton's two sides and move in lock-step through the lift, the carry and the set-down (TCP deltas).

1. Line up: both palms `LINE_UP` out from the carton's sides, palms in, finger rows along the sides, thumbs up.
2. Squeeze: move in to `SQUEEZE` past the sides (the arms' stiffness presses the palms on); bend the fingers onto
   the sides (`CURL`).
3. Lift the carton's bottom `CLEARANCE` above the shelf's top, both hands in step.
4. Carry it over the shelf's centre.
5. Set down: lower to `SET_DOWN_GAP` above the shelf's top.
6. Release: open both hands, wait 5 steps, move both out along the palm normals; hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.bimanual import close_hands, glide
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.carry_box_to_shelf_hands import CLEARANCE, SIDES, CarryBoxToShelfHandsEnv
from maniladder_ms.solvers.postures import LEAP_SYNERGIES

LINE_UP = 0.06  # the palms line up this far out from the sides before moving in
SQUEEZE = 0.01  # each TCP's target this far past the carton's side: the arms' stiffness presses the palms on
CURL = LEAP_SYNERGIES["knuckle_curl"]
SET_DOWN_STEP = 0.006  # m a control step of the set-down
SET_DOWN_GAP = 0.004  # the carton's bottom this far above the shelf's top when the hands let go
RELEASE_WAIT = 5  # control steps the opened hands rest before moving out


def grip_poses(task: CarryBoxToShelfHandsEnv) -> dict[str, tuple[torch.Tensor, torch.Tensor, torch.Tensor]]:
    """Per side, (p, q, n): the TCP pose at which that hand's palm lies flat on the carton's side (palm in,
    finger row along the side, thumb up; `grip_points`) and the palm normal `n` (into the carton),
    (num_envs, 3 / 4 / 3) each."""
    return {side: (p, tcp_quat(normal, torch.cross(normal, ex, dim=1)), normal)
            for side, (p, normal, ex) in task.grip_points().items()}


@register_solver("CarryBoxToShelfHands", control_modes=TCP_DELTA_MODES)
def solve_carry_box_to_shelf_hands(env, seed: int) -> dict:
    """Both hands line up beside the carton, palms in, finger rows along its sides and thumbs up; move in
    and press, bend the fingers onto the sides; lift in step, carry over the shelf, lower onto it; open,
    move out."""
    with DrivenSolver.episode(env, seed) as s:
        task: CarryBoxToShelfHandsEnv = env.unwrapped
        up = torch.tensor([[0.0, 0.0, 1.0]], device=task.device)
        grips = {f"{side}_arm": grip for side, grip in grip_poses(task).items()}
        s.move({arm: (p - LINE_UP * n, q) for arm, (p, q, n) in grips.items()}, max_steps=80)
        s.move({arm: (p + SQUEEZE * n, q) for arm, (p, q, n) in grips.items()}, max_steps=25)
        close_hands(s, {f"{side}_hand": CURL for side in SIDES}, ramp_steps=10)
        held = {arm: p + SQUEEZE * n for arm, (p, q, n) in grips.items()}
        rise = (task.shelf_height + CLEARANCE) * up
        glide(s, {arm: (p, p + rise, grips[arm][1]) for arm, p in held.items()}, settle_steps=5)
        shift = task.shelf.pose.p - task.box.pose.p
        shift[:, 2] = 0
        glide(s, {arm: (p + rise, p + rise + shift, grips[arm][1]) for arm, p in held.items()}, settle_steps=5)
        down = (task.shelf_height + SET_DOWN_GAP) * up
        glide(s, {arm: (p + rise + shift, p + down + shift, grips[arm][1]) for arm, p in held.items()},
              step_length=SET_DOWN_STEP, settle_steps=10)
        for side in SIDES:
            s.release(f"{side}_hand", steps=0)
        for _ in range(RELEASE_WAIT):
            s.step()
        glide(s, {arm: (p + down + shift, p + down + shift - (SQUEEZE + LINE_UP) * grips[arm][2], grips[arm][1])
                  for arm, p in held.items()}, settle_steps=5)
        s.hold_until_success()
        return s.info
