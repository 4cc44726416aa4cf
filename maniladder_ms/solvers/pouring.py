"""Solver phase of the pouring tasks (`tasks.particles.pour_particles.base.CupToBowl`): roll a held cup about an
axis fixed in the hand while steering its measured mouth over the receiving container (PourWaterHand,
PourWaterBimanual, PourGrainsHandToCup)."""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import axis_angle_to_quaternion, quaternion_apply, quaternion_multiply

from .driven import DrivenSolver


def cup_mouth(task) -> torch.Tensor:
    """World position (n, 3) of the centre of the pouring cup's (`task.cup`) mouth, from its measured pose."""
    local = torch.tensor([0.0, 0.0, task.cup_shape.inner[-1][0]], device=task.device).expand(task.num_envs, 3)
    return task.cup.pose.p + quaternion_apply(task.cup.pose.q, local)


def steer_roll(s: DrivenSolver, task, arm: str, axis: torch.Tensor, q: torch.Tensor, end: torch.Tensor,
               rim_z: torch.Tensor, roll: float, roll_steps: int, hold_steps: int, clear: float = 0.02):
    """Roll the held cup by `roll` rad about the world `axis` (n, 3) from the TCP orientation `q` over
    `roll_steps` control steps, its mouth moving along a straight line from where it is to `end` (n, 3) and
    never so low that the cup's lower bottom edge comes within `clear` of `rim_z` (n,), the receiver's rim
    height; then hold the last pose `hold_steps` steps. Stops early once the task succeeds."""
    start = cup_mouth(task)
    height = task.cup_shape.inner[-1][0]
    radius = task.cup_shape.inner[-1][1] + task.cup_shape.wall
    for k in range(1, roll_steps + hold_steps + 1):
        f = min(k, roll_steps) / roll_steps
        tilt = roll * f
        goal = start + (end - start) * f
        floor = rim_z + clear + max(0.0, height * np.cos(tilt)) + radius * np.sin(tilt)
        goal[:, 2] = torch.maximum(goal[:, 2], floor)
        turn = axis_angle_to_quaternion(axis * tilt)
        s.step({arm: (s.tcp(arm).p + goal - cup_mouth(task), quaternion_multiply(turn, q))})
        if bool(s.info["success"].all()):
            return
