"""Scripted solver of MobileFetchMug (tasks/rigid/mobile_fetch_mug.py): drive the base along the main table until
the mug lies straight ahead of the arm, pinch its rim as HangMug's solver does, drive back until the zone lies ahead
and set the mug down there (TCP deltas and base velocity).

1. Rise: the TCP up to `CARRY_HEIGHT`, clear of both tables.
2. Drive out: the base sideways until the rim grasp point (`objects.mug.rim_point`) lies straight ahead.
3. Pick: pinch the rim opposite the handle top-down, fingers across the wall, and lift to `CARRY_HEIGHT`.
4. Drive back at `CARRY_SPEED` until the zone lies ahead, the arm riding with the base.
5. Set down: the mug's bottom 5 cm over the zone's centre, then `SET_DOWN_GAP` above the table; open, rise 10 cm;
   hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.solvers.control import drive_base_to, top_down_quat
from maniladder_ms.geometry import yaw_of
from maniladder_ms.objects.mug import rim_point
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.mobile_fetch_mug import MobileFetchMugEnv

CARRY_HEIGHT = 0.2  # TCP height above the table top while the base drives: the hanging mug clears both tables
CARRY_SPEED = 0.6  # fraction of the base's top speed while the mug hangs in the gripper
OVER_ZONE = 0.05  # m: the mug's bottom first comes this far over the zone's centre
SET_DOWN_GAP = 0.005  # the mug's bottom this far above the table when the gripper opens
RETREAT = 0.1  # m the open gripper rises off the placed mug


@register_solver("MobileFetchMug", control_modes=TCP_DELTA_MODES)
def solve_mobile_fetch_mug(env, seed: int) -> dict:
    """Lift the TCP clear of the mug, drive the base sideways until the rim grasp point lies straight ahead of
    the arm, grasp the rim opposite the handle top-down (HangMug's grasp) and lift; drive back until the zone
    lies ahead, the arm riding with the base; lower the mug into the zone, open and rise."""
    with DrivenSolver.episode(env, seed) as robot:
        task: MobileFetchMugEnv = env.unwrapped
        n, device = task.num_envs, task.device
        base_start = task.agent.base_pose.clone()
        grasp_p = rim_point(task.mug, task.mug_shape)
        grasp_yaw = robot.neutral_yaw(yaw_of(task.mug.pose.q) + np.pi / 2, np.pi)  # fingers closing across the wall
        q = top_down_quat(grasp_yaw, n, device=device)
        tcp = robot.tcp("arm").p.clone()
        robot.move({"arm": (torch.cat([tcp[:, :2], torch.full((n, 1), CARRY_HEIGHT, device=device)], dim=1), q)},
                   max_steps=40, pos_tol=0.01, rot_tol=0.05)
        # the base's y joint moves the arm along world y: put the grasp point straight ahead of the shoulder
        drive_base_to(robot, base_start + torch.stack([torch.zeros(n, device=device), grasp_p[:, 1] - tcp[:, 1],
                                                       torch.zeros(n, device=device)], dim=1), max_steps=150)
        robot.pick("arm", "gripper", grasp_p, grasp_yaw, lift=CARRY_HEIGHT - grasp_p[0, 2].item())
        zone = task.zone.pose.p
        drive_base_to(robot, base_start + torch.stack([torch.zeros(n, device=device), zone[:, 1] - tcp[:, 1],
                                                       torch.zeros(n, device=device)], dim=1), max_steps=200,
                      speed=CARRY_SPEED)

        def tcp_for_mug_at(xy, height):  # the TCP that puts the held mug's bottom centre over xy, `height` up
            mug = task.mug.pose.p
            goal = torch.cat([xy, torch.full((n, 1), height, device=device)], dim=1)
            return robot.tcp("arm").p + goal - mug

        robot.move({"arm": (tcp_for_mug_at(zone[:, :2], OVER_ZONE), q)}, max_steps=60, pos_tol=0.004)
        robot.move({"arm": (tcp_for_mug_at(zone[:, :2], SET_DOWN_GAP), q)}, max_steps=40, pos_tol=0.003)
        robot.release("gripper")
        robot.move({"arm": (robot.above(robot.tcp("arm").p, RETREAT), q)}, max_steps=20, pos_tol=0.01)
        robot.hold_until_success()
        return robot.info
