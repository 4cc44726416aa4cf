"""Scripted solver of CarryBoardThroughGate (tasks/rigid/lift_two_handed/carry_board_through_gate.py): both grippers
take the board near its ends, lift it, turn and line it up square in front of the gate's opening in the air, and
carry it straight through in lock-step.

1. Each arm comes down top-down over its grasp point (`grasp_points`), fingers across the board; both close and
   lift LIFT together (`lift_together`).
2. Each TCP's pose in the board's frame is read once both hold it; from then on the arms' targets are those
   poses composed with a planned board pose, so a grasp that slipped a little moves with the board.
3. Turn and shift: the planned board pose goes from where it was lifted to LINE_UP before the gate's middle,
   square to it, in TURN_STEPS equal steps (yaw and position together).
4. Carry: the planned pose advances along the gate's axis CARRY_STEP a control step until the board's centre
   is PAST beyond the gate's middle, then both hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, lift_together
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rigid.lift_two_handed.carry_board_through_gate import CarryBoardThroughGateEnv

LIFT = 0.05  # metres the grasp points rise: the board's bottom 5 cm up, its top 8 cm (the posts stand 12 cm)
LINE_UP = 0.12  # metres before the gate's middle the board's centre stops, square to the gate
TURN_STEPS = 50  # control steps of the turn and shift to the line-up pose
CARRY_STEP = 0.006  # metres per control step through the opening
PAST = 0.06  # metres beyond the gate's middle the board's centre ends (its half width and the posts' half depth
# are 4 cm: all of it past the far face with 2 cm to spare; at 9 cm the arms, stretched to a TCP 17 cm out in
# front of the robot at the board's height, sagged short of it with the gate 12 cm out)
SETTLE_STEPS = 15  # control steps the arms get to reach each end pose


@register_solver("CarryBoardThroughGate", control_modes=TCP_DELTA_MODES)
def solve_carry_board_through_gate(env, seed: int) -> dict:
    """Grasp both ends top-down, lift, turn square to the gate in front of it, carry it through."""
    with DrivenSolver.episode(env, seed) as s:
        task: CarryBoardThroughGateEnv = env.unwrapped
        n, device = task.num_envs, task.device
        # fingers close across the board (along its local x): the TCP's x along the board
        q = top_down_quat(DrivenSolver.neutral_yaw(yaw_of(task.board.pose.q) - np.pi / 2, np.pi), n, device)
        above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
        grasps = [Grasp(f"{side}_arm", f"{side}_gripper", p, q, above) for side, p in task.grasp_points().items()]
        lift_together(s, grasps, LIFT)
        board = task.board.pose
        held = {g.arm: board.inv() * s.tcp(g.arm) for g in grasps}
        start_p, start_yaw = board.p.clone(), yaw_of(board.q)
        gate = task.gate.pose
        gate_yaw = yaw_of(gate.q)
        axis = torch.stack([torch.cos(gate_yaw), torch.sin(gate_yaw), torch.zeros_like(gate_yaw)], dim=1)
        line_up = gate.p - LINE_UP * axis
        line_up[:, 2] = start_p[:, 2]
        turn = torch.remainder(gate_yaw - start_yaw + np.pi / 2, np.pi) - np.pi / 2  # the board is symmetric

        def targets(p: torch.Tensor, yaw: torch.Tensor) -> dict:
            planned = Pose.create_from_pq(p, yaw_quat(yaw))
            return {arm: ((planned * rel).p, (planned * rel).q) for arm, rel in held.items()}

        for k in range(1, TURN_STEPS + 1):
            t = k / TURN_STEPS
            s.step(targets(start_p + (line_up - start_p) * t, start_yaw + turn * t))
        yaw = start_yaw + turn
        s.move(targets(line_up, yaw), max_steps=SETTLE_STEPS)
        steps = int(np.ceil((LINE_UP + PAST) / CARRY_STEP))
        for k in range(1, steps + 1):
            s.step(targets(line_up + axis * (LINE_UP + PAST) * k / steps, yaw))
        s.move(targets(line_up + axis * (LINE_UP + PAST), yaw), max_steps=SETTLE_STEPS)
        s.hold_until_success()
        return s.info
