"""Scripted solver of ScrewNutOnBolt (tasks/articulated/screw_nut_on_bolt.py): the left gripper lifts the bolt by its
shaft and holds it upright; the right gripper screws the nut on in top-down strokes, clockwise from above.

1. The left gripper lines up beside the bolt while the right rises above the nut winding its wrist up the other way
   from the family's unscrewing strokes (counter-clockwise: Panda joint 7 to the low end of its range).
2. The left settles on its line-up point, moves in, closes across the shaft and lifts the bolt.
3. Strokes with the right gripper: grip the nut across its flats (the flats' yaw nearest the wound-up wrist), turn
   the wrist clockwise about the bolt's axis, following the nut down, until joint 7 nears its high limit; let go,
   rise, turn the open hand back, grip again, until the task reports success.
4. Hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_to_matrix

from maniladder_ms.geometry import matrix_yaw, tcp_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import (J7_LIMIT, J7_MARGIN, LEAD, grip_target, rise_first, tcp_yaw, turn_wrist,
                                         wrist_angle)
from maniladder_ms.tasks.articulated.screw_nut_on_bolt import ScrewNutOnBoltEnv

# the left gripper holds the shaft from the +y side (pointing along world -y, fingers closing along world x), its
# TCP this high above the bolt's base: clear of the table below (the sideways hand reaches ~6 cm below its TCP)
HOLD_HEIGHT = 0.065
LEFT_APPROACH = 0.15  # m out from the bolt where the left lines up
LIFT = 0.035  # m the left lifts the bolt: lift_height plus a margin for the sag of the held bolt
LINE_UP_STEPS = 100  # at most this many control steps for the line-up and the wind-up
LINED_UP_POS_TOL, LINED_UP_ROT_TOL = 0.01, 0.05  # m, rad: the left is lined up
SETTLE_STEPS, SETTLE_POS_TOL, SETTLE_ROT_TOL = 40, 0.005, 0.03  # the left's line-up made exact before it moves in
MOVE_IN_STEPS, MOVE_IN_POS_TOL = 40, 0.003
LIFT_STEPS = 30
CLEARANCE = 0.08  # m above the nut's top where the right winds its wrist up
ABOVE_NUT = 0.03  # m above the nut's top where the open right hand turns back between strokes
FLATS = np.pi / 3  # the nut's flats repeat every sixth of a turn
REACH_STEPS, REACH_POS_TOL = 30, 0.003
MAX_STROKES, STROKE_STEPS = 4, 200
RELEASE_STEPS = 5
BACK_MARGIN = 0.3  # rad: the open hand turns back this much more than the rest of the turn needs
FOLLOW = 0.9  # the share of the wrist's turn the nut takes (the rest slips)


def wound(s: DrivenSolver, arm: str) -> torch.Tensor:
    """(n,) joint 7 is at the low end of its range, where a clockwise stroke begins."""
    return wrist_angle(s, arm) <= -J7_LIMIT + J7_MARGIN


def nut_grip_point(task: ScrewNutOnBoltEnv) -> torch.Tensor:
    """(n, 3) the nut's centre (mid-height on the bolt's axis), where the right TCP grips it, as it stands now."""
    return task.nut_top() - torch.tensor([0.0, 0.0, task.BOLT.nut_height / 2], device=task.device)


def flats_yaw(s: DrivenSolver, task: ScrewNutOnBoltEnv, arm: str) -> torch.Tensor:
    """(n,) of the TCP yaws whose fingers close across the nut's flats (a box of the hex ring faces the nut's x
    axis; the fingers close along the TCP's y, a quarter turn from its x), the one nearest the TCP's yaw now."""
    nut = matrix_yaw(quaternion_to_matrix(task.nut.pose.q))
    base = nut - np.pi / 2
    return base + torch.round((tcp_yaw(s, arm) - base) / FLATS) * FLATS


@register_solver("ScrewNutOnBolt", control_modes=TCP_DELTA_MODES)
def solve_screw_nut_on_bolt(env, seed: int) -> dict:
    """Left: sideways grasp across the bolt's shaft and lift; right: top-down grip on the nut's flats and clockwise
    strokes until the nut has run far enough down."""
    with DrivenSolver.episode(env, seed) as s:
        task: ScrewNutOnBoltEnv = env.unwrapped
        n, device = task.num_envs, task.device
        arm, ee = "right_arm", "right_gripper"
        hold_p = task.bolt.pose.p + torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=device)
        pointing = torch.tensor([[0.0, -1.0, 0.0]], device=device).expand(n, 3)
        closing = torch.tensor([[1.0, 0.0, 0.0]], device=device).expand(n, 3)
        hold = Grasp("left_arm", "left_gripper", hold_p, tcp_quat(pointing, closing), -LEFT_APPROACH * pointing)
        up = torch.tensor([0.0, 0.0, 1.0], device=device)

        def wind_up():
            above = rise_first(s, arm, task.nut_top() + CLEARANCE * up)
            return grip_target(above, tcp_yaw(s, arm) + torch.where(wound(s, arm), 0.0, LEAD))

        for _ in range(LINE_UP_STEPS):
            errs = s.step({"left_arm": hold.lined_up, arm: wind_up()})
            ep, er = errs["left_arm"]
            if bool((ep < LINED_UP_POS_TOL).all() and (er < LINED_UP_ROT_TOL).all() and wound(s, arm).all()):
                break
        s.move({"left_arm": hold.lined_up}, max_steps=SETTLE_STEPS, pos_tol=SETTLE_POS_TOL, rot_tol=SETTLE_ROT_TOL)
        s.move({"left_arm": (hold.p, hold.q)}, max_steps=MOVE_IN_STEPS, pos_tol=MOVE_IN_POS_TOL)
        s.grasp("left_gripper")
        s.move({"left_arm": (hold.p + LIFT * up, hold.q), arm: wind_up()}, max_steps=LIFT_STEPS)
        screw_on(s, task, arm, ee)
        s.hold_until_success()
        return s.info


def screw_on(s: DrivenSolver, task: ScrewNutOnBoltEnv, arm: str, ee: str):
    """The right gripper's strokes (see the module docstring), until success or `MAX_STROKES`."""
    up = torch.tensor([0.0, 0.0, 1.0], device=task.device)

    def done():
        return bool(s.info.get("success", torch.zeros(1, dtype=torch.bool)).all())

    for _ in range(MAX_STROKES):
        yaw = flats_yaw(s, task, arm)
        s.move(lambda: {arm: grip_target(nut_grip_point(task), yaw)}, max_steps=REACH_STEPS, pos_tol=REACH_POS_TOL)
        s.grasp(ee)
        turn_wrist(s, arm, lambda: nut_grip_point(task), -1,
                   lambda: done() or bool((wrist_angle(s, arm) >= J7_LIMIT - J7_MARGIN).all()), max_steps=STROKE_STEPS)
        if done():
            return
        s.release(ee, steps=RELEASE_STEPS)
        high = lambda: task.nut_top() + ABOVE_NUT * up  # noqa: E731
        s.move({arm: grip_target(high(), tcp_yaw(s, arm))}, max_steps=20, pos_tol=0.01)
        back_to = wrist_angle(s, arm) - back_turn(s, task, arm)
        turn_wrist(s, arm, high, 1, lambda: bool(((wrist_angle(s, arm) <= back_to) | wound(s, arm)).all()),
                   max_steps=STROKE_STEPS)


def back_turn(s: DrivenSolver, task: ScrewNutOnBoltEnv, arm: str) -> torch.Tensor:
    """(n,) how far (rad) the open hand turns back counter-clockwise: the rest of the turn (divided by `FOLLOW`,
    the share of the wrist's turn the nut takes) plus `BACK_MARGIN`, rounded up to where the fingers face the
    nut's flats again (down, where joint 7 has not that much range left)."""
    rest = (task.min_advance - task.memory["held_advance"][:, 0]) / task.thread_pitch * (2 * np.pi)
    want = rest / FOLLOW + BACK_MARGIN
    offset = tcp_yaw(s, arm) - flats_yaw(s, task, arm)  # (-FLATS/2, FLATS/2]: the hand's yaw past the nearest flats
    up_to = torch.ceil((want + offset) / FLATS) * FLATS - offset
    room = wrist_angle(s, arm) + J7_LIMIT - J7_MARGIN
    return torch.where(up_to <= room, up_to, up_to - FLATS)
