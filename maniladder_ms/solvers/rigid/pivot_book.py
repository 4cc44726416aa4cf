"""Scripted solver of PivotBook (tasks/rigid/pivot_book.py): non-prehensile, the closed fingers lift the book's
near end by friction on its end face and then follow the end's arc about the far bottom edge (TCP deltas).

1. Approach: close the gripper; come down `START_BACK` in front of the near end face, fingertips `START_UP` above
   the book's bottom.
2. Friction lift: press the end face lightly (target `PRESS_DEPTH` inside it) and slide up until the book is tilted
   by `RAISE_START`.
3. Follow the arc: keep the fingertips at the rising end's bottom edge, the target `LEAD` ahead along the arc, until
   `NEAR_UPRIGHT` short of vertical.
4. Rise straight up `CLEAR` (the fingers carry the book the last degrees onto its end face against the wall), back
   off `CLEAR` from the wall; hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.pivot_book import PivotBookEnv

TIP_BELOW_TCP = 0.01  # the Panda's closed fingertips reach about this far below its tcp
FINGER_HALF_THICKNESS = 0.01  # closed Panda fingers, from the tcp to their outer face
START_BACK = 0.03  # m in front of the near end face where the fingertips come down
START_UP = 0.01  # m above the book's bottom where the fingertips start
APPROACH_ABOVE = 0.08  # m above the start where the descent begins
RAISE_START = np.deg2rad(5)  # book tilt from which the finger can get under its near end
PRESS_DEPTH = 0.025  # how far into the end face the finger is aimed while sliding up it
SLIDE_UP_STEP = 0.02  # m a control step's target lies above the fingertips while sliding up the end face
LEAD = 0.35  # rad: the finger's target runs this far ahead of the book along the near end's arc
ARC_BELOW = 0.005  # m the fingertips' target lies below the rising end's bottom edge
NEAR_UPRIGHT = 0.05  # rad short of vertical where the finger stops following the arc
CLEAR = 0.06  # m the finger rises along the standing book's top end, then backs off from the wall


@register_solver("PivotBook", control_modes=TCP_DELTA_MODES)
def solve_pivot_book(env, seed: int) -> dict:
    """Lift the book's near end by pressing its end face with the closed fingers and sliding them up
    (friction raises the end while the wall holds the far end), then keep the fingertips under the
    rising end, following its arc about the far bottom edge until the book stands against the wall."""
    with DrivenSolver.episode(env, seed) as robot:
        task: PivotBookEnv = env.unwrapped
        n, device = task.num_envs, task.device
        hx, _, hz = task.book_half_size
        yaw = yaw_of(task.book.pose.q)
        toward_wall = torch.stack([torch.cos(yaw), torch.sin(yaw), torch.zeros_like(yaw)], dim=1)
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        q = top_down_quat(robot.neutral_yaw(yaw, np.pi / 2), n, device=device)
        tip_to_tcp = TIP_BELOW_TCP * up
        robot.grasp("gripper")
        near_face = task.book.pose.p - toward_wall * hx
        start = near_face - toward_wall * START_BACK + up * (START_UP - hz)
        robot.move({"arm": (start + up * APPROACH_ABOVE + tip_to_tcp, q)}, max_steps=60)
        robot.move({"arm": (start + tip_to_tcp, q)}, max_steps=30, pos_tol=0.004)
        # friction lift: press the end face lightly (the target just inside it) and slide up
        for _ in range(60):
            if bool((task.evaluate()["tilt_up"] >= RAISE_START).all()):
                break
            tip = robot.tcp("arm").p - tip_to_tcp
            target = task.book.pose.p - task.book_axis() * (hx + FINGER_HALF_THICKNESS - PRESS_DEPTH)
            target[:, 2] = tip[:, 2] + SLIDE_UP_STEP
            robot.step({"arm": (target + tip_to_tcp, q)})
        # follow the near end's arc about the far bottom edge, fingertips at the end's bottom edge
        def tcp_at(tilt):
            axis = task.book_axis()
            normal = quaternion_apply(task.book.pose.q, torch.tensor([0.0, 0, 1.0], device=device).expand(n, 3))
            pivot = task.book.pose.p + axis * hx - normal * hz
            phi = tilt.clamp(max=np.pi / 2)  # past vertical would drive the top into the wall and kick the foot out
            along = -torch.cos(phi)[:, None] * toward_wall + torch.sin(phi)[:, None] * up
            below = -torch.sin(phi)[:, None] * toward_wall - torch.cos(phi)[:, None] * up
            return pivot + along * 2 * hx + below * ARC_BELOW + tip_to_tcp

        robot.follow_arc("arm", q, lambda: task.evaluate()["tilt_up"], tcp_at, lead=LEAD,
                         stop_at=np.pi / 2 - NEAR_UPRIGHT, max_steps=80)
        # rise straight up along the book's top end: the fingers' friction carries it the last degrees
        # onto its end face, flat against the wall, where it stands (short of that it falls back, so
        # backing away first fails); then back off
        clear = robot.above(robot.tcp("arm").p, CLEAR)
        robot.move({"arm": (clear, q)}, max_steps=15, pos_tol=0.01)
        robot.move({"arm": (clear - toward_wall * CLEAR, q)}, max_steps=15, pos_tol=0.01)
        robot.hold_until_success()
        return robot.info
