"""Scripted solver of LiftRopeHand (tasks/rope/lift_rope_hand.py): pinch the rope's middle capsule between the
LEAP hand's index and middle fingers (the "scissor" pinch) and lift it slowly, the halves hanging down.

1. Open the index and middle fingers straight and spread (`scissor_open`).
2. Come down over the middle capsule, fingers along the rope.
3. Swing the two fingers together over `SCISSOR_RAMP_STEPS`.
4. Lift `LIFT` in `LIFT_STEPS` steps.
5. Hold still until success.
"""

from __future__ import annotations

from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.rope.lift_rope_hand import LiftRopeHandEnv

LIFT = 0.28  # the grasped capsule ends 29 cm up, the rope hanging straight down both sides: 19 of 20 capsule centres above 10 cm
LIFT_STEPS = 45  # 6 mm a control step: faster lifts (25 steps for 25 cm) swing the rope out of the pinch


def pinch_and_lift(s: DrivenSolver, task: LiftRopeHandEnv):
    """Take the middle capsule top-down between the straight index and middle fingers (fingers along the
    rope, tips spread), swing the two fingers together (the "scissor" pinch) and lift `LIFT` slowly."""
    link = task.rope.links[task.grasp_segment]
    centre = link.pose.p.clone()
    centre[:, 2] = task.rope_config.radius
    tcp, q = DrivenSolver.scissor_pose(centre, rope.segment_yaw(link.pose.q))
    s.set_ee("hand", "scissor_open", steps=1)
    s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
    s.move({"arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
    s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
    for k in range(1, LIFT_STEPS + 1):
        s.step({"arm": (s.above(tcp, LIFT * k / LIFT_STEPS), q)})


@register_solver("LiftRopeHand", control_modes=TCP_DELTA_MODES)
def solve_lift_rope_hand(env, seed: int) -> dict:
    """`pinch_and_lift` the middle capsule, then hold still until the rope is up."""
    with DrivenSolver.episode(env, seed) as s:
        pinch_and_lift(s, env.unwrapped)
        s.hold_until_success()
        return s.info
