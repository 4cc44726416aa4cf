"""Scripted solver of PlugUSB (tasks/rigid/plug_usb.py): pick the standing plug by its housing, turn it in the
hand to the socket's yaw (its rib to the groove), line its tip up over the slot and push it in, closed loop on
the measured plug in the hand.

1. Grasp the housing from above, fingers across its wide faces (of the two such grasps, the one that leaves the
   wrist nearest its middle once the plug is turned to the socket); lift.
2. Carry the plug `CARRY_ABOVE` over the slot, turned so its rib faces the groove (`plug_goal_tcp`).
3. Line the tip up over the slot's axis to within `LINE_UP_TOL`, `HOVER` above the top face.
4. Go down `DESCENT_STEP` a control step to `FLOOR_GAP` above the slot's floor; open; back off upwards.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import wrap_angle, yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.plug_usb import PlugUSBEnv

PLUG_LIFT = 0.08  # metres the plug is lifted off the table before the carry
CARRY_ABOVE = 0.04  # the plug is first carried to this far above its HOVER pose
HOVER = 0.004  # the tip this high over the socket's top face while it is lined up with the slot
LINE_UP_TOL = 0.0002  # m: the tip's lateral offset from the slot's axis before going down
HOVER_TOL = 0.002  # m: the line-up is done once the tip is no lower than this below HOVER too
DESCENT_STEP = 0.001  # m per control step the target goes down
FLOOR_GAP = 0.002  # the descent stops with the tip this high over the slot's floor
FLOOR_TOL = 0.001  # m: the descent is done once the tip is within this of FLOOR_GAP
BACK_OFF = 0.06  # m the open gripper rises after letting go
LINE_UP_STEPS, MAX_DESCENT_STEPS = 60, 40


def plug_goal_tcp(task: PlugUSBEnv, plug_in_tcp: Pose, tip_height: float):
    """(p, q) of the TCP that puts the held plug (`plug_in_tcp`: where it sits in the hand) on the slot's axis,
    its tip `tip_height` above the socket's top face, turned to the socket's yaw (its rib towards the groove)."""
    n = task.num_envs
    local_p = torch.zeros(n, 3, device=task.device)
    local_p[:, 2] = task.shape.socket_top + tip_height
    local_q = torch.zeros(n, 4, device=task.device)
    local_q[:, 0] = 1
    goal = task.socket.pose * Pose.create_from_pq(local_p, local_q) * plug_in_tcp.inv()
    return goal.p, goal.q


@register_solver("PlugUSB", control_modes=TCP_DELTA_MODES)
def solve_plug_usb(env, seed: int) -> dict:
    """Grasp the housing from above; carry the plug over the slot turned to the socket's yaw; line up; push in;
    open; back off."""
    with DrivenSolver.episode(env, seed) as s:
        task: PlugUSBEnv = env.unwrapped
        plug_yaw = yaw_of(task.plug.pose.q)
        turn = wrap_angle(yaw_of(task.socket.pose.q) - plug_yaw)
        # fingers close along the plug's x (across the housing's wide faces): TCP yaw plug_yaw + pi/2 (mod pi);
        # of the two, the one whose yaw after the turn, and on the way there, stays nearest zero
        grasp = DrivenSolver.neutral_yaw(plug_yaw + np.pi / 2 + turn / 2, np.pi) - turn / 2
        centre = task.plug.pose.p.clone()
        centre[:, 2] += task.shape.connector_length + task.shape.housing_half[2]
        s.pick("arm", "gripper", centre, grasp, lift=PLUG_LIFT)
        grip = task.ee.tcp().inv() * task.plug.pose
        s.move({"arm": plug_goal_tcp(task, grip, HOVER + CARRY_ABOVE)}, max_steps=120, pos_tol=0.003, rot_tol=0.03)
        grip = task.ee.tcp().inv() * task.plug.pose
        for _ in range(LINE_UP_STEPS):
            s.step({"arm": plug_goal_tcp(task, grip, HOVER)})
            info = task.insertion_state()
            if bool((info["offset"] < LINE_UP_TOL).all() & (info["depth"] > -HOVER - HOVER_TOL).all()):
                break
        height, bottom = HOVER, -(task.shape.slot_depth - FLOOR_GAP)
        for _ in range(MAX_DESCENT_STEPS):
            height = max(height - DESCENT_STEP, bottom)
            s.step({"arm": plug_goal_tcp(task, grip, height)})
            if bool((task.insertion_state()["depth"] >= task.shape.slot_depth - FLOOR_GAP - FLOOR_TOL).all()):
                break
        s.release("gripper", steps=8)
        tcp = s.tcp("arm")
        s.move({"arm": (s.above(tcp.p, BACK_OFF), tcp.q)}, max_steps=20, pos_tol=0.01)
        s.hold_until_success()
        return s.info
