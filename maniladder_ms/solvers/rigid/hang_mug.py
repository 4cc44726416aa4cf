"""Scripted solver of HangMug (tasks/rigid/hang_mug.py): a rim pinch opposite the handle, the mug turned so the
handle's opening looks along the peg, then slid onto the peg closed loop (TCP deltas).

1. Pick: grasp the rim opposite the handle (`objects.mug.rim_point`) top-down, fingers closing across the wall, and
   lift 20 cm.
2. Line up: carry the mug, turned by the smaller of the two turns that point the opening along the peg (world y),
   to 3 cm above the point just beyond the peg's tip.
3. Aim: put the opening's centre (where it really is: the mug may sit tilted in the grasp) beyond the tip.
4. Slide: along the peg to `SLIDE_ON` from its root, then down by `REST_DROP` onto the peg.
5. Release and rise 8 cm; hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import wrap_angle
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.objects.mug import rim_point
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.hang_mug import HangMugEnv

LIFT = 0.2  # m the TCP rises after the rim grasp
BEYOND_TIP = 0.05  # m past the peg's tip where the opening is lined up
LINE_UP_ABOVE = 0.03  # m the opening first arrives above that point
SLIDE_ON = 0.07  # how far along the peg (from its root) the handle's opening is carried
REST_DROP = 0.018  # then lowered by this much: the handle's upper arm comes to rest on the peg
RETREAT = 0.08  # m the open gripper rises off the hanging mug


@register_solver("HangMug", control_modes=TCP_DELTA_MODES)
def solve_hang_mug(env, seed: int) -> dict:
    """Grasp the rim opposite the handle, lift, turn the mug so the handle's opening faces along the
    peg, slide the handle onto the peg, lower it onto the peg, let go."""
    with DrivenSolver.episode(env, seed) as robot:
        task: HangMugEnv = env.unwrapped
        n, device = task.num_envs, task.device
        shape = task.mug_shape
        mug_yaw = yaw_of(task.mug.pose.q)
        grasp_p = rim_point(task.mug, shape)
        grasp_yaw = robot.neutral_yaw(mug_yaw + np.pi / 2, np.pi)  # fingers closing across the wall
        robot.pick("arm", "gripper", grasp_p, grasp_yaw, lift=LIFT)
        # the mug turned so its handle's opening looks along the peg (world y): yaw 0 or pi, whichever
        # is the smaller turn; the grasp carries it as a rigid offset from the tcp
        turn = wrap_angle(-mug_yaw * 2) / 2  # in (-pi/2, pi/2]: to the nearest multiple of pi
        tcp_in_mug = task.mug.pose.inv() * robot.tcp("arm")
        target_yaw = mug_yaw + turn
        q = top_down_quat(grasp_yaw + turn, n, device=device)
        oc = torch.as_tensor(shape.opening_centre(), dtype=torch.float32, device=device).expand(n, 3)

        def tcp_for_opening_at(point):  # tcp position that puts the opening's centre at `point`
            return robot.tcp("arm").p + point - task.opening_centre()

        def tcp_for_opening_at_turned(point):  # the same, for the mug turned to target_yaw (before the turn)
            turned = yaw_quat(target_yaw)
            return (Pose.create_from_pq(point - quaternion_apply(turned, oc), turned) * tcp_in_mug).p

        root = task.peg_root()
        beyond_tip = root + torch.tensor([0.0, task.peg_length + BEYOND_TIP, 0.0], device=device)
        on_peg = root + torch.tensor([0.0, SLIDE_ON, 0.0], device=device)
        robot.move({"arm": (robot.above(tcp_for_opening_at_turned(beyond_tip), LINE_UP_ABOVE), q)}, max_steps=60,
                   pos_tol=0.008)
        # from here on aim with the opening where it really is: the mug may sit a little tilted in the grasp
        robot.move({"arm": (tcp_for_opening_at(beyond_tip), q)}, max_steps=30, pos_tol=0.004)
        robot.move({"arm": (tcp_for_opening_at(on_peg), q)}, max_steps=40, pos_tol=0.004)
        robot.move({"arm": (tcp_for_opening_at(on_peg - torch.tensor([0.0, 0.0, REST_DROP], device=device)), q)},
                   max_steps=15, pos_tol=0.004)
        robot.release("gripper")
        robot.move({"arm": (robot.above(robot.tcp("arm").p, RETREAT), q)}, max_steps=20, pos_tol=0.01)
        robot.hold_until_success()
        return robot.info
