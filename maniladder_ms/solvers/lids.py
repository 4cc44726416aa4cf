"""Opening a hinged lid (`objects.boxes`) by lifting its lip: a solver phase of OpenBoxRetrieval and
OpenLidHoldBox."""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import axis_angle_to_matrix, matrix_to_quaternion
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import yaw_of
from maniladder_ms.objects.boxes import LiddedBoxShape, lid_angle

from .driven import DrivenSolver

PUSH_TO = np.deg2rad(100)  # past vertical the lid falls the rest of the way onto its open limit
LEAD = 0.3  # rad: the fingers' target runs this far ahead of the lid along the arc
# the hand points at the lip from outside the box, towards the hinge, tilted this far below horizontal,
# so the fingertips reach under the overhang. Boxes are best hinged on the robot's side: the hand then
# tilts back towards the robot (Panda joint 6 straightens); tilting it forward bends joint 6 towards
# the wrist's singular range and its IK winds joints 5 and 7 onto their limits.
PITCH = np.deg2rad(45)
# fingertips this far in from the lip's edge, and below its face deep enough that the tilted fingers
# pass under the edge with 1 cm to spare
TIP_IN = 0.02
UNDER_LIP = (TIP_IN, TIP_IN * np.tan(PITCH) + 0.01)
TIP_FROM_TCP = 0.01  # the Panda's fingertips lie about this far beyond its tcp
# as the lid rises the target slides this much further in from the edge, so the fingertips keep pushing
# the lid's underside instead of slipping off its edge
SLIDE_IN = 0.04


def _lid_pose(box, shape: LiddedBoxShape, angle: torch.Tensor) -> Pose:
    """World pose of the lid frame at `angle` (b,), from the box body's current pose."""
    axis_angle = torch.zeros(len(angle), 3, device=angle.device)
    axis_angle[:, 1] = angle
    hinge = torch.as_tensor(shape.hinge_in_body(), dtype=torch.float32, device=angle.device).expand(len(angle), 3)
    return box.pose * Pose.create_from_pq(hinge, matrix_to_quaternion(axis_angle_to_matrix(axis_angle)))


def open_lid(robot: DrivenSolver, arm: str, ee_part: str, box, shape: LiddedBoxShape, max_steps: int = 60):
    """Lift the lid by its lip with the closed fingers: they reach under the lip from the robot's
    side, then follow the lip's arc (closed loop on the lid angle, the hand keeping its orientation)
    until the lid is pushed past vertical; then the hand backs off and rises clear."""
    n = robot.base.num_envs
    device = box.pose.p.device
    q = _hook_quat(box)
    tip_to_tcp = -TIP_FROM_TCP * _approach(box)
    lip = torch.as_tensor(shape.lip_in_lid(), dtype=torch.float32, device=device)
    lip = lip + torch.tensor([UNDER_LIP[0], 0.0, -UNDER_LIP[1]], device=device)

    def tcp_target(angle):  # (b,) lid angle -> world TCP target with the fingertips under the lid
        inward = SLIDE_IN * (angle / (np.pi / 2)).clamp(0, 1)
        tip = Pose.create_from_pq(lip + inward[:, None] * torch.tensor([1.0, 0.0, 0.0], device=device))
        return (_lid_pose(box, shape, angle) * tip).p + tip_to_tcp

    robot.grasp(ee_part)
    start = tcp_target(torch.zeros(n, device=device))
    behind = start - 0.06 * _approach(box)
    robot.move({arm: (robot.above(behind, 0.05), q)}, max_steps=60)
    robot.move({arm: (behind, q)}, max_steps=20, pos_tol=0.004)
    robot.move({arm: (start, q)}, max_steps=20, pos_tol=0.004)
    robot.follow_arc(arm, q, lambda: lid_angle(box), lambda angle: tcp_target(angle.clamp(max=PUSH_TO + LEAD)),
                     lead=LEAD, stop_at=PUSH_TO, max_steps=max_steps)
    back = robot.tcp(arm).p - 0.05 * _approach(box)
    robot.move({arm: (back, q)}, max_steps=15, pos_tol=0.01)
    robot.move({arm: (robot.above(back, 0.1), q)}, max_steps=20, pos_tol=0.01)


def _approach(box) -> torch.Tensor:
    """(b, 3) unit pointing direction of the hand: towards the hinge (body +x), PITCH below horizontal."""
    yaw = yaw_of(box.pose.q)
    c = np.cos(PITCH)
    return torch.stack([c * torch.cos(yaw), c * torch.sin(yaw), torch.full_like(yaw, -np.sin(PITCH))], dim=1)


def _hook_quat(box) -> torch.Tensor:
    """(b, 4) TCP orientation: z along `_approach`, fingers closing along the hinge (body y), side by side
    under the lip; of the gripper's two such orientations, the one with y nearer the rest pose's
    (world -y), so the wrist turns least."""
    yaw = yaw_of(box.pose.q)
    z = _approach(box)
    y = torch.stack([torch.sin(yaw), -torch.cos(yaw), torch.zeros_like(yaw)], dim=1)
    y = y * torch.where(y[:, 1:2] > 0, -1.0, 1.0)
    x = torch.cross(y, z, dim=1)
    return matrix_to_quaternion(torch.stack([x, y, z], dim=2))
