"""OpenJarBimanual (L2 rigid DG, family UnscrewCap): the left arm holds a jar, the right twists its lid off."""

from __future__ import annotations


import torch

from maniladder_ms.envs import register_task
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, tcp_quat
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import is_wound_up, rise_first, unscrew, wind_up_target

from .base import UnscrewCapTask


@register_task("OpenJarBimanual")
class OpenJarBimanualEnv(UnscrewCapTask):
    """**Task:** a screw-top jar stands free on the table; the left gripper holds its body from the side
    while the right gripper grips the lid from above and twists it counter-clockwise (seen from above),
    in strokes: twist, let go, turn the open hand back, grip again, until the lid is off its thread.

    **Randomisation:** the jar (a 6 cm wide, 11 cm tall sealed body of ~0.4 kg and a 6.6 cm wide, 2.2 cm
    tall lid screwed home; `objects.jar`) has its centre uniform in x in [-0.12, -0.04], y in
    [-0.05, 0.05] and its yaw (where the lid's stripes point) uniform in [0, 2 pi).

    **Success:** (the UnscrewCap family rule, `UnscrewCapTask`) the lid's thread joint has turned by at
    least `release_angle` counter-clockwise, and so has the episode memory `held_turn`, which counts the
    joint's turn only over control steps in which one gripper held the lid (`ee.holds`) while the other
    held the jar's body. The thread resists with `thread_torque` of dry friction: a jar that the other
    gripper does not hold spins with the lid.

    **Level 2:** (against Level 1's OpenLidHoldBox: a hinged lid pushed open once, ~100 degrees, while the
    other arm holds the box; 150-step horizon) the lid needs one and a half turns, more than the Panda's
    wrist turns in one go (joint 7 spans 5.8 rad, 332 degrees, and turns at most ~0.037 rad a control
    step), so it takes two strokes with a regrasp between them: 6 stages (hold the jar, grip the lid,
    twist, let go and turn back, grip again, twist), ~460 control steps; the holding gripper carries the
    thread's torque all along (let go, the jar spins and nothing counts), and the twisting grip stays
    centred on the lid's axis within a few millimetres over ~10 rad of wrist turn.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.22, 0.06, -0.15, 0.25)


# the left gripper holds the jar's body from the +y side (pointing along world -y, fingers closing along
# world x), its TCP this high: clear of the table below (the sideways hand reaches ~6 cm below its TCP)
# and of the right gripper's fingers on the lid above
HOLD_HEIGHT = 0.065
LINE_UP_STEPS = 70
LEFT_APPROACH = 0.15  # m out from the jar where the left lines up (nearer, its turning hand knocked the jar)
RIGHT_CLEARANCE = 0.1  # m above the lid where the right hand winds up (its approach passes high over the lid)


@register_solver("OpenJarBimanual", control_modes=TCP_DELTA_MODES)
def solve_open_jar_bimanual(env, seed: int) -> dict:
    """Left: sideways grasp across the jar's body; right: top-down grip on the lid and twist strokes
    (`solvers.twist.unscrew`) until the lid is off."""
    with DrivenSolver.episode(env, seed) as s:
        task: OpenJarBimanualEnv = env.unwrapped
        n, device = task.num_envs, task.device
        centre = task.jar.pose.p
        hold_p = centre + torch.tensor([0.0, 0.0, HOLD_HEIGHT], device=device)
        pointing = torch.tensor([[0.0, -1.0, 0.0]], device=device).expand(n, 3)
        closing = torch.tensor([[1.0, 0.0, 0.0]], device=device).expand(n, 3)
        hold = Grasp("left_arm", "left_gripper", hold_p, tcp_quat(pointing, closing),
                     -LEFT_APPROACH * pointing)
        # the left lines up beside the jar while the right goes above the lid and winds its wrist up
        def high():  # above the lid (`rise_first`: the rest pose's hand is level with the lid top)
            return rise_first(s, "right_arm", task.lid_top() + torch.tensor([0.0, 0.0, RIGHT_CLEARANCE], device=device))
        for _ in range(LINE_UP_STEPS):
            errs = s.step({"left_arm": hold.lined_up, "right_arm": wind_up_target(s, "right_arm", high())})
            ep, er = errs["left_arm"]
            if bool((ep < 0.01).all() and (er < 0.05).all()) and is_wound_up(s, "right_arm"):
                break
        s.move({"left_arm": hold.lined_up}, max_steps=40, pos_tol=0.005, rot_tol=0.03)
        s.move({"left_arm": (hold.p, hold.q)}, max_steps=40, pos_tol=0.003)
        s.grasp("left_gripper")
        unscrew(s, task, "right_arm", "right_gripper")
        s.hold_until_success()
        return s.info
