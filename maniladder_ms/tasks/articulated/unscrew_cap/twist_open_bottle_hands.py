"""TwistOpenBottleHands (L3 rigid DX, family UnscrewCap): the left LEAP hand holds a free narrow-necked bottle, the
right twists its small cap off through two full turns."""

from __future__ import annotations

from maniladder_ms.envs import register_task
from maniladder_ms.objects.jar import JarShape
from maniladder_ms.agents.poses import READY_ARM_JOINTS

from .base import UnscrewCapTask

HOLDER, TWISTER = "left", "right"  # the hand that holds the bottle's body, the hand that twists the cap


@register_task("TwistOpenBottleHands")
class TwistOpenBottleHandsEnv(UnscrewCapTask):
    """**Task:** a capped bottle stands free on the table (nothing fixes it); the left LEAP hand holds its
    body from the side while the right LEAP hand pinches the small cap on the bottle's neck from above
    (fingers against the thumb) and twists it off counter-clockwise (seen from above) by turning the wrist,
    in strokes: grip, twist, let go, turn the open hand back, grip again, until the cap is off its thread.

    **Randomisation:** the bottle (a 6 cm wide, 16 cm tall sealed body of ~0.6 kg, a `BOTTLE.neck_radius`
    neck and a `BOTTLE.lid_radius` cap screwed home on it; `objects.jar`) has its centre uniform in x in
    `jar_x_range`, y in `jar_y_range`; its yaw (where the cap's stripes point) uniform in `jar_yaw_range`.

    **Success:** (the UnscrewCap family rule, `UnscrewCapTask`) the cap's thread joint has turned by at
    least `release_angle` counter-clockwise, and so has the episode memory `held_turn`, which counts the
    joint's turn only over control steps in which one hand held the cap (`ee.holds`: a finger pressing
    against the thumb or palm) while the other hand held the bottle's body. The thread resists with
    `thread_torque` of dry friction, and the cap advances only as it is turned: a turn made while the
    other hand does not hold the bottle does not count, and the free bottle spins with a cap twisted
    without it.

    **Level 3:** (against Level 2's OpenJarHands: a 6.6 cm wide, 3.5 cm tall lid turned 360 degrees in one or
    two strokes, 326-657 control steps, mean 459) the cap is 4.6 cm wide and 2.2 cm tall on a 3.2 cm neck: the
    pinch closes on a rim 1 cm nearer the axis with 1.3 cm less of it to hold, and the same thread torque
    asks 1.4 times the fingertip force (2.2 N at the rim against 1.5 N); and it turns twice as far, 720
    degrees: 12.6 rad, more than twice what the wrist turns the cap in one stroke (~5.2 rad within joint 7's
    5.8-radian range), so always three strokes with two regrasps and two turn-backs between them: 8 stages
    (hold the bottle, grip the cap, twist, let go and turn back, grip again, twist, let go and turn back, grip
    and twist), each regrasp on a cap off its home stop, while the other hand holds the free bottle upright
    throughout: 916-1131 control steps (mean 1012) in the solver's episodes on seeds 100-149, about twice
    OpenJarHands'.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.0, -0.15, 0.25)
    # the holding arm starts in the side-grasp ready pose (`agents.poses.READY_ARM_JOINTS`, as OpenJarHands'); the
    # twisting arm at rest
    READY_JOINTS = {f"{HOLDER}_panda_joint{i}": angle for i, angle in enumerate(READY_ARM_JOINTS[HOLDER], 1)}
    # OpenJarHands' body (the holding grasp's), a neck that lifts the cap clear of the holding hand's fingers
    # and a small cap
    BOTTLE = JarShape(body_radius=0.03, body_height=0.16, neck_radius=0.016, neck_height=0.02,
                      lid_radius=0.023, lid_height=0.022)
    jar_shape = BOTTLE
    body_color, lid_color = (0.55, 0.8, 0.6, 1), (0.85, 0.25, 0.5, 1)
