"""Scripted solver of PushBlocksBimanual (tasks/rigid/push_blocks_bimanual.py): both arms at once push their own
block along the line through its zone's centre with the closed gripper (TCP deltas).

1. Close both grippers; each comes down `APPROACH_HEIGHT` above its start point, `BEHIND` behind the block on the
   line through the zone centre, fingers side by side across that line, then to `PUSH_HEIGHT`.
2. Push: glide along the line at `PUSH_STEP` a control step until the block's centre is on the zone's.
3. Rise `RISE`; hold until success.
"""

from __future__ import annotations

import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rigid.push_blocks_bimanual import SIDES, PushBlocksBimanualEnv

PUSH_HEIGHT = 0.02  # TCP height while pushing: the closed fingertips just clear the table
BEHIND = 0.025  # gap between the fingers and the block before the push
FINGER_HALF = 0.01  # the closed fingers' half thickness along the push
PUSH_STEP = 0.008  # metres per control step (16 cm/s): the block does not slide on ahead of the fingers
RISE = 0.05  # m the grippers rise off the pushed blocks


@register_solver("PushBlocksBimanual", control_modes=TCP_DELTA_MODES)
def solve_push_blocks_bimanual(env, seed: int) -> dict:
    """Both arms at once: closed gripper down behind the block on the line through the zone centre,
    push along that line until the block centre is on the zone centre, rise."""
    with DrivenSolver.episode(env, seed) as s:
        task: PushBlocksBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        starts, ends = {}, {}
        for side in SIDES:
            block_p, zone_p = task.blocks[side].pose.p.clone(), task.zones[side].pose.p.clone()
            heading = (zone_p - block_p) * torch.tensor([1.0, 1.0, 0.0], device=device)
            heading = torch.nn.functional.normalize(heading, dim=1)
            contact = task.block_half + FINGER_HALF  # TCP to block centre when touching
            start, end = block_p - heading * (contact + BEHIND), zone_p - heading * contact
            start[:, 2] = end[:, 2] = PUSH_HEIGHT
            # fingers side by side across the push line: closing axis (the TCP's y) perpendicular to it
            yaw = torch.atan2(heading[:, 1], heading[:, 0])
            starts[side], ends[side] = (start, top_down_quat(yaw, n, device)), end
        for side in SIDES:
            s.grip(True, f"{side}_gripper", steps=0)
        s.move({f"{side}_arm": (s.above(p, APPROACH_HEIGHT), q) for side, (p, q) in starts.items()}, max_steps=60,
               pos_tol=0.01)
        s.move({f"{side}_arm": (p, q) for side, (p, q) in starts.items()}, max_steps=30)
        glide(s, {f"{side}_arm": (p, ends[side], q) for side, (p, q) in starts.items()}, step_length=PUSH_STEP,
              settle_steps=10)
        s.move({f"{side}_arm": (s.above(ends[side], RISE), q) for side, (_, q) in starts.items()}, max_steps=15,
               pos_tol=0.02)
        s.hold_until_success()
        return s.info
