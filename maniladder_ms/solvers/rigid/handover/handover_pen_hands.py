"""Scripted solver of HandoverPenHands (tasks/rigid/handover/handover_pen_hands.py): both hands hold the pen in the
index / middle "scissor" pinch, top-down, the left near one end, the right near the other.

1. Pick: the right goes to wait high on its side (TAKER_WAIT) in the background while the left scissor-pinches the
   pen GRASP_OFFSET from its centre towards its +y end and lifts it (`pick`).
2. Carry: the left carries it level to MEET, the pen's centre there (`carry`).
3. Take: the right comes over the pen's other half, GRASP_OFFSET from the centre towards its -y end, from above
   and from its own side, comes down and closes its scissor pinch (`take`).
4. Swap: the left swings its fingers apart and rises, then moves aside; the right lifts the pen (`swap`).
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import HandoverSolver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, SCISSOR_RAMP_STEPS, DrivenSolver
from maniladder_ms.tasks.rigid.handover.handover_pen_hands import HandoverPenHandsEnv

# scissor_pose's `around`: the way each arm points across the table; HAND_TURN turns each hand half a turn from
# there, its TCP (the palm) outwards of its pinch and its pinching fingers towards the pen's centre: the TCPs
# 12 cm apart instead of 4 (facing palms at pinches 7 cm apart stopped the right 10 cm from the left, seed 100)
ARM_YAW = {"left": np.pi / 2, "right": -np.pi / 2}
HAND_TURN = {"left": np.pi, "right": np.pi}
# the scissor postures with the ring finger tucked under the palm: "scissor"'s flat ring reaches past the knuckles,
# where the two hands' rings met (seed 100)
OPEN, PINCH = "scissor_open_ring_tucked", "scissor_ring_tucked"
# 1. pick
# m: each hand pinches this far from the pen's centre along its axis (left +y, right -y), 1.5 cm from the pen's
# ends: at 0.035 and 0.045 the right hand's knuckles met the left's coming down (seed 100), at 0.055 they clear
GRASP_OFFSET = 0.055
GIVER_LIFT = 0.2  # m the left lifts the pen straight up (clear of the table by 19 cm before it moves sideways)
LIFT_STEPS = 30  # ... over this many control steps (6.7 mm a step; LiftRopeHand lifts its rope at 6 mm)
TAKER_WAIT = (-0.05, -0.25, 0.4)  # where the right waits top-down during the pick: turning on its way to the
# take from its rest pose it swept its fingers through the held pen (seed 100)
# 2. carry
MEET = (-0.05, 0.0, 0.25)  # the pen's centre while the right takes it: in front of the robot's middle, 25 cm up
# 3. take
TAKER_ABOVE = 0.1  # m: the right comes over its pinch this far above it, then straight down
TAKER_SIDE = 0.08  # m: ... and before that this far out towards -y along the pen
# 4. swap
GIVER_RISE = 0.1  # m the left rises after swinging its fingers apart
GIVER_OPEN_STEPS = 10  # control steps the left's fingers swing apart before it rises
GIVER_ASIDE = (0.0, 0.15, 0.05)  # then moves this far aside
TAKER_LIFT = 0.03  # m the right lifts the pen once alone


def pen_axis(task: HandoverPenHandsEnv) -> torch.Tensor:
    """The pen's axis (num_envs, 3), the way that points to +y."""
    x = torch.tensor([[1.0, 0.0, 0.0]], device=task.device).expand(task.num_envs, 3)
    u = quaternion_apply(task.pen.pose.q, x)
    return torch.where(u[:, 1:2] < 0, -u, u)


def pinch_pose(task: HandoverPenHandsEnv, side: str, centre: torch.Tensor):
    """(TCP p, q) of `side`'s top-down scissor pinch on the pen GRASP_OFFSET from `centre` towards its end on that
    side's half (left: +y)."""
    u = pen_axis(task)
    point = centre + u * (GRASP_OFFSET if side == "left" else -GRASP_OFFSET)
    return DrivenSolver.scissor_pose(point, torch.atan2(u[:, 1], u[:, 0]), mirror=side == "left",
                                     around=ARM_YAW[side] + HAND_TURN[side])


def pick(s: HandoverSolver, task: HandoverPenHandsEnv):
    """The right waits at TAKER_WAIT; the left scissor-pinches the pen lying on the table and lifts it."""
    dev, n = task.device, task.num_envs
    centre = task.pen.pose.p.clone()
    centre[:, 2] = task.pen_radius
    _, rq = pinch_pose(task, "right", centre)
    s.set_ee("right_hand", OPEN, steps=0)
    s.arm_targets["right_arm"] = (torch.tensor([TAKER_WAIT], device=dev).expand(n, 3), rq)
    tcp, q = pinch_pose(task, "left", centre)
    s.set_ee("left_hand", OPEN, steps=1)
    s.move({"left_arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
    s.move({"left_arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
    s.close_hand("left_hand", PINCH, ramp_steps=SCISSOR_RAMP_STEPS)
    for k in range(1, LIFT_STEPS + 1):
        s.step({"left_arm": (s.above(tcp, GIVER_LIFT * k / LIFT_STEPS), q)})


def carry(s: HandoverSolver, task: HandoverPenHandsEnv):
    """The left carries the pen level, its centre to MEET."""
    meet = torch.tensor([MEET], device=task.device).expand(task.num_envs, 3)
    tcp = s.tcp("left_arm")
    s.move({"left_arm": (meet - (task.pen.pose.p - tcp.p), tcp.q.clone())}, max_steps=80, pos_tol=0.005)


def take(s: HandoverSolver, task: HandoverPenHandsEnv):
    """The right comes over its pinch from its side, high, then down onto it, and closes its scissor pinch."""
    tcp, q = pinch_pose(task, "right", task.pen.pose.p.clone())
    u = pen_axis(task)
    high = s.above(tcp, TAKER_ABOVE)
    s.move({"right_arm": (high - u * TAKER_SIDE, q)}, max_steps=60, pos_tol=0.01)
    s.move({"right_arm": (high, q)}, max_steps=40)
    s.move({"right_arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
    s.close_hand("right_hand", PINCH, ramp_steps=SCISSOR_RAMP_STEPS)


def swap(s: HandoverSolver, task: HandoverPenHandsEnv):
    """The left swings its fingers apart and rises, then moves aside; the right lifts the pen a little."""
    s.set_ee("left_hand", OPEN, steps=GIVER_OPEN_STEPS)
    tcp = s.tcp("left_arm")
    s.move({"left_arm": (s.above(tcp.p, GIVER_RISE), tcp.q)}, max_steps=30, pos_tol=0.01)
    s.move({"left_arm": (tcp.p + torch.tensor(GIVER_ASIDE, device=task.device), tcp.q)}, max_steps=30, pos_tol=0.02)
    r = s.tcp("right_arm")
    s.move({"right_arm": (s.above(r.p, TAKER_LIFT), r.q)}, max_steps=20)


@register_solver("HandoverPenHands", control_modes=TCP_DELTA_MODES)
def solve_handover_pen_hands(env, seed: int) -> dict:
    """Phases 1-4 of the module docstring."""
    with HandoverSolver.episode(env, seed) as s:
        task: HandoverPenHandsEnv = env.unwrapped
        pick(s, task)
        carry(s, task)
        take(s, task)
        swap(s, task)
        s.hold_until_success()
        return s.info
