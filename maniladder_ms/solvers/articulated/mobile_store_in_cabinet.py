"""Scripted solver of MobileStoreInCabinet (tasks/articulated/mobile_store_in_cabinet.py): drive the base along the
main table until the drawer's handle lies straight ahead of the arm, pull the drawer open by its handle, drop the
block into it and push the drawer closed by the handle (TCP deltas and base velocity).

1. Rise: the TCP up to `CARRY_HEIGHT`, clear of both tables and the cabinet.
2. Drive: the base sideways until the handle lies straight ahead of the arm.
3. Open: grasp the handle bar top-down, fingers closing along the slide (either side of the bar), and pull the
   drawer out by `PULL` in steps of `PULL_STEP`; let go and rise.
4. Drive back to the start x (the pull pushed the base back), the block straight ahead; pick it top-down
   (fingers across two faces) and lift it to `CARRY_HEIGHT`.
5. Place: carry it over the middle of the drawer's open part, lower it to `DROP_GAP` above the drawer's floor,
   open, rise.
6. Close: drive back until the handle lies ahead, grasp it again and push it `PUSH_PAST` beyond the closed position (the slide's stop holds the
   drawer at closed) in steps of `PULL_STEP`; let go, rise; hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.control import drive_base_to, top_down_quat
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.geometry import yaw_of
from maniladder_ms.tasks.articulated.mobile_store_in_cabinet import MobileStoreInCabinetEnv

CARRY_HEIGHT = 0.22  # TCP height above the table top while driving and carrying: the held block clears the
# cabinet's top (15 cm)
PULL = 0.15  # m the drawer is pulled out: its open part (~14.5 cm) takes the 4 cm block with room to spare
PULL_STEP = 0.01  # m the TCP target moves along the slide a control step while pulling or pushing
PUSH_PAST = 0.02  # m the push's last target lies past the closed handle position (1 cm left seed 100's drawer
# 1.07 cm open)
DROP_GAP = 0.01  # the block's bottom this far above the drawer's floor when the gripper opens
HANDLE_YAW = np.pi / 2  # TCP x axis along world y: the fingers close along x, one each side of the bar (closing
# along y, they landed on the bar: seed 100)


@register_solver("MobileStoreInCabinet", control_modes=TCP_DELTA_MODES)
def solve_mobile_store_in_cabinet(env, seed: int) -> dict:
    """Rise, drive the base until the handle lies ahead, pull the drawer open by the handle, pick the block, drop
    it into the drawer, push the drawer closed by the handle, let go."""
    with DrivenSolver.episode(env, seed) as robot:
        task: MobileStoreInCabinetEnv = env.unwrapped
        n, device = task.num_envs, task.device
        shape = task.cabinet_shape
        handle_yaw = robot.neutral_yaw(torch.full((n,), HANDLE_YAW, device=device), np.pi)
        q_handle = top_down_quat(handle_yaw, n, device=device)
        tcp = robot.tcp("arm").p.clone()
        robot.move({"arm": (_at_height(tcp, CARRY_HEIGHT), q_handle)}, max_steps=40, pos_tol=0.01, rot_tol=0.05)
        # the base's y joint moves the arm along world y: put the handle straight ahead of the shoulder
        base_start = task.agent.base_pose.clone()
        handle = task.handle_position()
        drive_base_to(robot, base_start + _along_y(handle[:, 1] - tcp[:, 1]), max_steps=200)

        _slide_handle(robot, task, handle_yaw, -PULL)

        # the pull pushed the base back along x: drive it back to its start x, the block straight ahead
        drive_base_to(robot, base_start + _along_y(task.block.pose.p[:, 1] - tcp[:, 1]), max_steps=100)
        yaw = robot.neutral_yaw(yaw_of(task.block.pose.q), np.pi / 2)
        block = task.block.pose.p.clone()
        robot.pick("arm", "gripper", block, yaw, lift=CARRY_HEIGHT - block[0, 2].item())
        # carried and set down square to the drawer: the hand's long side (along the fingers' closing) across the
        # slide, clear of the front panel
        q_block = top_down_quat(torch.zeros(n, device=device), n, device=device)
        # the middle of the drawer's open part: between the carcass front and the front panel's inner face
        front = task.cabinet.pose.p[:, 0] - shape.depth / 2
        inner_face = task.handle_position()[:, 0] + shape.bar_standoff + shape.front
        goal = torch.stack([(front + inner_face) / 2, task.cabinet.pose.p[:, 1],
                            torch.full((n,), shape.floor_z + task.BLOCK_HALF + DROP_GAP, device=device)], dim=1)

        def tcp_for_block_at(p):  # the TCP that puts the held block's centre at p
            return robot.tcp("arm").p + p - task.block.pose.p

        robot.move({"arm": (tcp_for_block_at(_at_height(goal, CARRY_HEIGHT - task.BLOCK_HALF)), q_block)},
                   max_steps=80, pos_tol=0.01)
        robot.move({"arm": (tcp_for_block_at(goal), q_block)}, max_steps=60, pos_tol=0.004)
        robot.release("gripper")
        robot.move({"arm": (_at_height(robot.tcp("arm").p, CARRY_HEIGHT), q_block)}, max_steps=30, pos_tol=0.01)

        drive_base_to(robot, base_start + _along_y(task.handle_position()[:, 1] - tcp[:, 1]), max_steps=100)
        _slide_handle(robot, task, handle_yaw, task.opening() + PUSH_PAST)
        robot.hold_until_success()
        return robot.info


def _at_height(p: torch.Tensor, z: float) -> torch.Tensor:
    return torch.cat([p[:, :2], torch.full_like(p[:, :1], z)], dim=1)


def _along_y(dy: torch.Tensor) -> torch.Tensor:
    zeros = torch.zeros_like(dy)
    return torch.stack([zeros, dy, zeros], dim=1)


def _slide_handle(robot: DrivenSolver, task: MobileStoreInCabinetEnv, yaw: torch.Tensor, distance):
    """Grasp the handle bar top-down, fingers closing across `yaw`, move it `distance` (m, per sub-scene; + pushes
    in along +x) in `PULL_STEP` steps, let go and rise to `CARRY_HEIGHT`."""
    handle = task.handle_position()
    q = top_down_quat(yaw, task.num_envs, device=task.device)
    robot.pick("arm", "gripper", handle, yaw, lift=0)
    distance = torch.as_tensor(distance, dtype=torch.float32, device=task.device).expand(task.num_envs)
    steps = int(np.ceil(float(distance.abs().max()) / PULL_STEP))
    for k in range(1, steps + 1):
        target = handle.clone()
        target[:, 0] += distance * k / steps
        robot.move({"arm": (target, q)}, max_steps=3, pos_tol=0.004)
    robot.move({"arm": (handle + torch.stack([distance, 0 * distance, 0 * distance], dim=1), q)}, max_steps=20,
               pos_tol=0.004)
    robot.release("gripper")
    robot.move({"arm": (_at_height(robot.tcp("arm").p, CARRY_HEIGHT), q)}, max_steps=30, pos_tol=0.01)
