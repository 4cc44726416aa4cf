"""Scripted solver of PingPongTransport (tasks/rigid/lift_two_handed/ping_pong_transport.py): both grippers take the
tray's end walls and carry it to the zone in lock-step, slowly enough that the ball stays on the tray.

1. Each arm comes down top-down over its end wall's grasp point (`wall_points`), fingers across the wall.
2. Both close and lift LIFT together.
3. Both carry the tray over the zone in lock-step at CARRY_STEP.
4. Both lower it to SET_DOWN_GAP above the table, open and rise (`top_down_carry`).
"""

from __future__ import annotations

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import top_down_carry
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.lift_two_handed.ping_pong_transport import PingPongTransportEnv

LIFT = 0.08  # metres the grasp points rise: the tray's bottom 8 cm up
CARRY_STEP = 0.006  # metres per control step of the carry (LIFT_STEP is 0.01): the ball rolls less hard into a rim
SET_DOWN_GAP = 0.003  # the tray's bottom this far above the table when the grippers open


@register_solver("PingPongTransport", control_modes=TCP_DELTA_MODES)
def solve_ping_pong_transport(env, seed: int) -> dict:
    """Each arm grasps its end wall top-down, fingers across it; both lift together, carry the tray over the
    zone in lock-step, lower it onto the table, open and rise."""
    with DrivenSolver.episode(env, seed) as s:
        task: PingPongTransportEnv = env.unwrapped
        top_down_carry(s, task.wall_points(), yaw_of(task.tray.pose.q), LIFT, task.zone.pose.p - task.tray.pose.p,
                       SET_DOWN_GAP, carry_step=CARRY_STEP)
        s.hold_until_success()
        return s.info
