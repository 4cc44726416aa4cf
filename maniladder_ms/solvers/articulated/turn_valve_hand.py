"""Scripted solver of TurnValveHand (tasks/articulated/turn_valve_hand.py): the pointing index finger goes down
between two spokes, behind the spoke it will push, and the whole hand orbits the valve's axis the arrow's way.

1. Point the index finger and bring the hand above the hub, top-down at its starting yaw.
2. Of the spokes' gaps, pick the one that puts the TCP nearest the axis, the fingertip `FINGER_BEHIND_SPOKE` behind
   a spoke, `FINGER_RADIUS` from the axis, `FINGER_BELOW_WHEEL` below the wheel's top (`finger_point`).
3. Come down onto that point from `ABOVE_FINGER_POINT` above it.
4. Orbit the hand about the valve's axis by `HAND_TURN` in `TURN_STEP` steps, turning its yaw with it, until the
   hand has turned the wheel `TURN_PAST_GOAL` past the task's `turn_angle`: a policy imitating demonstrations that
   stopped at the goal stopped short of it (the ladder's round 2 on demos stopping at 90 deg: the greatest turn's
   median 79 deg, 14 of 50 at 90).
5. Hold until success.

The hand's yaw sweeps symmetrically about 0 (from -HAND_TURN / 2 the arrow's way) to stay well inside the Panda's
wrist range.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply, quaternion_invert

from maniladder_ms.agents.effectors import leap_fingertip

from maniladder_ms.geometry import wrap_angle
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import yaw_of
from maniladder_ms.objects.controls import turn_direction, valve_angle
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.articulated.turn_valve_hand import TurnValveHandEnv

HUB_CLEARANCE, HUB_STEPS, HUB_POS_TOL = 0.15, 25, 0.01  # m above the hub where the hand first goes; its move's limits
FINGER_RADIUS = 0.06  # m from the axis where the fingertip goes down
FINGER_BEHIND_SPOKE = np.radians(30)  # how far behind the spoke it will push
FINGER_BELOW_WHEEL = 0.02  # m below the wheel's top
ABOVE_FINGER_POINT = 0.08  # m above its finger point where the hand comes down from
DESCENT_STEPS, DESCENT_POS_TOL = 30, 0.003  # each of the two moves down: control steps at most; the last one's m
TURN_PAST_GOAL = np.radians(25)  # how far past `turn_angle` the hand turns the wheel before it lets go
HAND_TURN = np.radians(150)  # the turn, past the goal, the way to the spoke and a margin
TURN_STEP, TURN_STEP_MAX_STEPS = np.radians(10), 3  # each orbit step and its control steps at most


def finger_point(task: TurnValveHandEnv, axis: torch.Tensor, direction: torch.Tensor,
                 tip_offset: torch.Tensor) -> torch.Tensor:
    """(num_envs, 3) where the fingertip goes down: `FINGER_BEHIND_SPOKE` behind a spoke (against `direction`),
    `FINGER_RADIUS` from `axis` (the hub), in the gap that puts the TCP nearest the axis given the fingertip's
    world offset `tip_offset` from the TCP."""
    spoke0 = yaw_of(task.valve.pose.q) + valve_angle(task.valve)
    gap = 2 * np.pi / task.valve_shape.spokes
    want = torch.atan2(tip_offset[:, 1], tip_offset[:, 0])  # the finger's angle with the TCP on the axis
    behind_spoke0 = spoke0 - direction * FINGER_BEHIND_SPOKE
    finger_angle = behind_spoke0 + torch.round(wrap_angle(want - behind_spoke0) / gap) * gap
    finger = axis + FINGER_RADIUS * torch.stack(
        [torch.cos(finger_angle), torch.sin(finger_angle), torch.zeros_like(finger_angle)], dim=1)
    finger[:, 2] -= FINGER_BELOW_WHEEL
    return finger


@register_solver("TurnValveHand", control_modes=TCP_DELTA_MODES)
def solve_turn_valve_hand(env, seed: int) -> dict:
    """Point the index finger, put it down behind a spoke, turn the hand about the valve's axis."""
    with DrivenSolver.episode(env, seed) as s:
        task: TurnValveHandEnv = env.unwrapped
        dev = task.device
        direction = turn_direction(task.arrow)
        axis = task.hub()
        yaw0 = -direction * HAND_TURN / 2
        s.set_ee("hand", "point", steps=1)
        q0 = top_down_quat(yaw0, task.num_envs, dev)
        s.move({"arm": (axis + torch.tensor([0.0, 0.0, HUB_CLEARANCE], device=dev), q0)}, max_steps=HUB_STEPS,
               pos_tol=HUB_POS_TOL)
        # the pointing fingertip's offset from the TCP in the TCP frame, then in the world at hand yaw yaw0
        tcp_pose = task.ee.tcp()
        tip_in_tcp = quaternion_apply(quaternion_invert(tcp_pose.q), leap_fingertip(task.agent) - tcp_pose.p)
        tip_offset = quaternion_apply(q0, tip_in_tcp)
        tcp = finger_point(task, axis, direction, tip_offset) - tip_offset
        above = torch.tensor([0.0, 0.0, ABOVE_FINGER_POINT], device=dev)
        s.move({"arm": (tcp + above, q0)}, max_steps=DESCENT_STEPS)
        s.move({"arm": (tcp, q0)}, max_steps=DESCENT_STEPS, pos_tol=DESCENT_POS_TOL)
        rel = tcp - axis
        goal = np.deg2rad(task.turn_angle) + TURN_PAST_GOAL
        for i in range(1, int(round(HAND_TURN / TURN_STEP)) + 1):
            if s.info and bool((s.info["hand_turned"] >= goal).all()):
                break
            turn = direction * i * TURN_STEP
            cos, sin = torch.cos(turn), torch.sin(turn)
            orbit = torch.stack([cos * rel[:, 0] - sin * rel[:, 1], sin * rel[:, 0] + cos * rel[:, 1], rel[:, 2]], dim=1)
            s.move({"arm": (axis + orbit, top_down_quat(yaw0 + turn, task.num_envs, dev))},
                   max_steps=TURN_STEP_MAX_STEPS)
        s.hold_until_success()
        return s.info
