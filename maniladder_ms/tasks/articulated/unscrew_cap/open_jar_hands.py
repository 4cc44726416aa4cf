"""OpenJarHands (L2 rigid DX, family UnscrewCap): the left LEAP hand holds a free jar, the right unscrews its lid."""

from __future__ import annotations

from maniladder_ms.envs import register_task
from maniladder_ms.objects.jar import JarShape
from maniladder_ms.agents.poses import READY_ARM_JOINTS

from .base import UnscrewCapTask

HOLDER, TWISTER = "left", "right"  # the hand that holds the jar's body, the hand that twists the lid


@register_task("OpenJarHands")
class OpenJarHandsEnv(UnscrewCapTask):
    """**Task:** a screw-top jar stands free on the table; the left LEAP hand holds its body from the side
    while the right LEAP hand pinches the lid's rim from above (fingers against the thumb) and unscrews it
    counter-clockwise (seen from above) by turning the wrist, in strokes: grip, twist, let go, turn the open
    hand back, grip again, until the lid is off its thread.

    **Randomisation:** the jar (a 6 cm wide, 16 cm tall sealed body of ~0.6 kg and a 6.6 cm wide, 3.5 cm
    tall lid screwed home; `objects.jar`) has its centre uniform in x in `jar_x_range`, y in `jar_y_range`; its
    yaw (where the lid's stripes point: two crossed stripes, a pattern that repeats every 90 degrees on the round
    jar) uniform in `jar_yaw_range`.

    **Success:** (the UnscrewCap family rule, `UnscrewCapTask`) the lid's thread joint has turned by at
    least `release_angle` counter-clockwise, and so has the episode memory `held_turn`, which counts the
    joint's turn only over control steps in which one hand held the lid (`ee.holds`: a finger pressing
    against the thumb or palm) while the other hand held the jar's body. The thread resists with
    `thread_torque` of dry friction; a turn made while the other hand does not hold the jar does not
    count.

    **Level 2:** (against Level 1's LiftBasketHands: both hands do the same thing, close on a handle and
    lift together, 2 stages, ~160 steps) the two hands do different things at once: one holds a free jar
    against the thread's torque throughout while the other turns the lid a full turn, 360 degrees, more
    than the Panda's wrist turns in one go with the lid slipping in the grip, so it takes two strokes with a
    regrasp between them: 6 stages (hold the jar, grip the lid, twist, let go and turn back, grip again,
    twist), 326-657 control steps (mean 459) in the solver's episodes on seeds 100-149 (50/50); the
    twisting grasp must stay centred on the lid's axis within ~1 cm while the wrist turns ~8 rad, and the jar, held
    only by the other hand, must not tip or turn in that hand's grip.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.0, -0.15, 0.25)
    # the holding arm starts in the side-grasp ready pose (`agents.poses.READY_ARM_JOINTS`: reached from the
    # top-down rest pose, the ~180 degree wrist turn took a wrong IK branch on ~30 % of seeds); the twisting arm at rest
    READY_JOINTS = {f"{HOLDER}_panda_joint{i}": angle for i, angle in enumerate(READY_ARM_JOINTS[HOLDER], 1)}
    jar_shape = JarShape(body_radius=0.03, body_height=0.16, lid_radius=0.033, lid_height=0.035)
    body_color, lid_color = (0.85, 0.75, 0.55, 1), (0.2, 0.45, 0.8, 1)

