"""Scripted solver of HandoverCube (tasks/rigid/handover/handover_cube.py): the left gripper picks the cube top-down
and brings it to a meeting point, where the right gripper, turned sideways, takes it and sets it down in the zone.

1. The right arm turns its hand sideways and lines up beside the meeting point (MEET_POINT).
2. The left picks the cube top-down across a face pair (`geometry.face_yaw`), its fingers on the cube's +y part.
3. The left lifts off the table, then carries the cube to the meeting point.
4. The right grasps the cube's -y part from the side; the left lets go and backs off upwards (`hand_over`).
5. The right carries the cube over the zone, lowers it, lets go PLACE_DROP above the table and backs off.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import face_yaw
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.bimanual import Grasp, hand_over, line_up
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.handover.handover_cube import HandoverCubeEnv

MEET_POINT = (-0.05, 0.0, 0.2)  # cube centre during the handover, between the arms
GIVER_OFFSET = 0.013  # the left fingers hold the cube's left (+y) part, the right fingers its right part
TAKER_OFFSET = 0.015
TAKER_APPROACH = 0.1  # the right hand comes in this far along +y (from the robot's right) to its grasp
GIVER_LIFT_OFF = 0.05  # the left rises this far off the table before it carries the cube to the meeting point
GIVER_RETREAT = (0.0, 0.05, 0.08)  # the left backs off this way after letting go
PLACE_HOVER = 0.05  # the right lines the cube up this far above its set-down point
PLACE_DROP = 0.015
TAKER_RETREAT = 0.08  # the right backs off this far along -y after letting go



@register_solver("HandoverCube", control_modes=TCP_DELTA_MODES)
def solve_handover_cube(env, seed: int) -> dict:
    """Phases 1-5 of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: HandoverCubeEnv = env.unwrapped
        device, n = task.device, task.num_envs
        y = torch.tensor([0.0, 1.0, 0.0], device=device)
        meet = torch.tensor([MEET_POINT], device=device).expand(n, 3)
        take_q = tcp_quat(y.expand(n, 3), torch.tensor([[1.0, 0.0, 0.0]], device=device).expand(n, 3))
        # the right arm turns its hand sideways and waits beside the meeting point while the left one picks
        line_up(s, Grasp("right_arm", "right_gripper", meet - TAKER_OFFSET * y, take_q, -TAKER_APPROACH * y))
        # the wrist turns by at most 45 degrees between the pick and the meeting point (yaw pi/2)
        pick_yaw = face_yaw(task.cube.pose.q, np.pi / 2)
        hand_x = torch.stack([torch.cos(pick_yaw), torch.sin(pick_yaw), torch.zeros_like(pick_yaw)], dim=1)
        grasp_p = task.cube.pose.p + GIVER_OFFSET * hand_x
        s.pick("left_arm", "left_gripper", grasp_p, pick_yaw, lift=0)
        # up off the table first, then straight to the meeting point
        s.move({"left_arm": (s.above(grasp_p, GIVER_LIFT_OFF), s.tcp("left_arm").q)}, max_steps=20, pos_tol=0.02)
        s.move({"left_arm": (meet + GIVER_OFFSET * y, top_down_quat(np.pi / 2, n, device))}, max_steps=60)
        taker = Grasp("right_arm", "right_gripper", task.cube.pose.p - TAKER_OFFSET * y, take_q, -TAKER_APPROACH * y)
        hand_over(s, "left_arm", "left_gripper", taker, giver_retreat=torch.tensor(GIVER_RETREAT, device=device))
        # put down over the zone centre; the sideways hand touches the table before the cube does, so the
        # cube is let go PLACE_DROP above it
        place = task.zone.pose.p - TAKER_OFFSET * y
        place[:, 2] = task.cube_half + PLACE_DROP
        s.move({"right_arm": (s.above(place, PLACE_HOVER), take_q)}, max_steps=60, pos_tol=0.01)
        s.move({"right_arm": (place, take_q)}, max_steps=30)
        s.release("right_gripper", steps=5)
        s.move({"right_arm": (place - TAKER_RETREAT * y, take_q)}, max_steps=20, pos_tol=0.02)
        s.hold_until_success()
        return s.info
