"""OpenJarBimanual (L2 rigid DG, family UnscrewCap): the left arm holds a jar, the right twists its lid off."""

from __future__ import annotations

from maniladder_ms.envs import register_task

from .base import UnscrewCapTask


@register_task("OpenJarBimanual")
class OpenJarBimanualEnv(UnscrewCapTask):
    """**Task:** a screw-top jar stands free on the table; the left gripper holds its body from the side
    while the right gripper grips the lid from above and twists it counter-clockwise (seen from above),
    in strokes: twist, let go, turn the open hand back, grip again, until the lid is off its thread.

    **Randomisation:** the jar (a 6 cm wide, 11 cm tall sealed body of ~0.4 kg and a 6.6 cm wide, 2.2 cm
    tall lid screwed home; `objects.jar`) has its centre uniform in x in `jar_x_range`, y in `jar_y_range`; its
    yaw (where the lid's stripes point: two crossed stripes, a pattern that repeats every 90 degrees on the round
    jar) uniform in `jar_yaw_range`.

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

