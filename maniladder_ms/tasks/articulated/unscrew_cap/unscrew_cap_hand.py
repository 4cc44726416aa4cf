"""UnscrewCapHand (L2 rigid SX, family UnscrewCap): one LEAP hand unscrews the cap of a bottle clamped to the table."""

from __future__ import annotations

from maniladder_ms.envs import register_task
from maniladder_ms.objects.jar import JarShape

from .base import UnscrewCapTask


@register_task("UnscrewCapHand")
class UnscrewCapHandEnv(UnscrewCapTask):
    """**Task:** a bottle stands clamped to the table (its body cannot move: one hand cannot both hold it
    and twist); the LEAP hand grips its cap from above in a power grasp and unscrews it counter-clockwise
    (seen from above) by turning the wrist, in strokes: grip, twist, let go, turn the open hand back,
    grip again, until the cap is off its thread.

    **Randomisation:** the bottle (an 8 cm wide, 11 cm tall body, a 4.4 cm wide, 3 cm tall neck and a
    6 cm wide, 3 cm tall cap screwed home; `objects.jar`) has its centre uniform in x in `jar_x_range`, y in
    `jar_y_range`; its yaw (where the cap's stripes point: two crossed stripes, a pattern that repeats every
    90 degrees on the round bottle) uniform in `jar_yaw_range`.

    **Success:** (the UnscrewCap family rule, `UnscrewCapTask`, for a clamped container) the cap's thread
    joint has turned by at least `release_angle` counter-clockwise, and so has the episode memory
    `held_turn`, which counts the joint's turn only over control steps in which the hand held the cap
    (`ee.holds`: a finger pressing against the thumb or palm); a cap pushed round by a touching finger
    does not count. The thread resists with `thread_torque` of dry friction.

    **Level 2:** (against Level 1's TurnValveHand: one finger pushes a wheel 70 degrees,
    touching is enough, one motion, 150-step horizon) the cap needs a full turn, 360 degrees, held in a
    grasp all along; the cap takes only ~0.8 of the wrist's turn (the fingers slip on it) and the wrist
    turns at most ~0.04 rad a control step, within Panda joint 7's 332-degree range, so it takes two
    strokes with a regrasp between them: 6 stages (wind the wrist up and reach the cap, grip, twist, let
    go and turn back, grip again, twist), ~470 control steps; the grasp must stay centred on the cap's
    axis within ~1 cm while the wrist turns ~8 rad.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    CLAMPED = True
    TASK_REGION = (-0.25, -0.03, -0.15, 0.15)
    jar_shape = JarShape(body_radius=0.04, body_height=0.11, neck_radius=0.022, neck_height=0.03,
                         lid_radius=0.03, lid_height=0.03)
    body_color, lid_color = (0.3, 0.6, 0.4, 1), (0.95, 0.75, 0.1, 1)

