"""Scripted solver of ThreadRopeThroughRingHands (tasks/rope/thread_rope_through_ring_hands.py): the right LEAP hand
feeds the rope's end through the ring and lays it on the ring's bottom; the left hand, waiting beyond the ring,
pinches the protruding end and pulls the rope through (the two big hands cannot both reach the rope within a
few cm of the ring).

1. Both hands open the scissor fingers; the left hand goes to wait above the far side (`WAIT_*`).
2. The right hand scissor-pinches capsule `FEED_CAPSULE` (fingers along the rope, facing the ring).
3. It lifts the pinch to `FEED_LIFT` above the ring's centre, `RUN_UP` before the stop, turned along the axis.
4. It feeds the end through, to `FEED_STOP` short of the ring's plane.
5. It lays the rope on the ring's bottom tube from `REST_Z`, lets go and backs off (`BACK_OFF_*`).
6. The left hand pinches capsule `TAKE_CAPSULE` where it lies, coming down from `TAKE_APPROACH` above it.
7. It pulls the rope `PULL` away from the ring, lowers it to the table, lets go and rises `LEFT_RETREAT`.
8. Hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_OFFSET, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.rope.thread_rope_through_ring_hands import (FEED_CAPSULE, FEED_SIDE,
                                                                   ThreadRopeThroughRingHandsEnv)

TAKE_CAPSULE = 1  # the pulling hand pinches this one beyond the ring
FEED_LIFT = 0.02  # the pinched capsule is fed this far above the ring's centre (the end droops a little)
FEED_STOP = 0.027  # the feeding pinch stops this far short of the ring's plane (fingertips ~1.5 cm from the tube)
REST_Z = 0.045  # the feeding hand lays the rope on the ring's bottom tube from this height, then lets go
PULL = 0.12  # the pulling hand draws the rope this far away from the ring
STEP = 0.006  # metres a control step while the rope is held (faster swings it out of the pinch)
WAIT_ASIDE = 0.1  # the waiting left hand's pinch point lies this far beyond the ring's centre, clear of the feed
WAIT_Z = 0.16  # and this high
RUN_UP = 0.04  # the feed starts this far before its stop, along the ring's axis
LIFT_SETTLE_STEPS = 3  # control steps held after each glide of the held rope, but
FEED_SETTLE_STEPS = 8  # those lining the end up with the ring and feeding it through
OPEN_STEPS = 6  # control steps to open a hand's scissor fingers
BACK_OFF_AWAY, BACK_OFF_UP = 0.04, 0.12  # the right hand's retreat from the laid rope: back along the axis, and up
TAKE_APPROACH = 0.05  # the left hand comes down onto the protruding end from this far above it
PULL_BELOW_CENTRE = 0.01  # the pulled capsule is drawn no lower than this below the ring's centre
LAY_DOWN_CLEARANCE = 0.004  # the pulled capsule is laid down this far above its resting height
LEFT_RETREAT = 0.08  # the left hand rises this far after letting go


@register_solver("ThreadRopeThroughRingHands", control_modes=TCP_DELTA_MODES)
def solve_thread_rope_through_ring_hands(env, seed: int) -> dict:
    """The right hand takes the rope `FEED_CAPSULE` capsules from its end in the "scissor" pinch (fingers along
    the rope, facing the ring), lifts it above the ring's centre and feeds the end through, lays the rope on the
    ring's bottom and lets go (the two big hands cannot both reach the rope within a few cm of the ring); the
    left hand, waiting above the far side, pinches the protruding end and pulls the rope `PULL` away from the
    ring, lowers it to the table, lets go and rises."""
    with DrivenSolver.episode(env, seed) as s:
        task: ThreadRopeThroughRingHandsEnv = env.unwrapped
        device = task.device
        centre, axis = task.ring_frame()
        toward = -FEED_SIDE  # the feed moves along +y * toward
        feed_yaw = torch.full((centre.shape[0],), toward * np.pi / 2, device=device)
        link = task.rope.links[FEED_CAPSULE]
        grip = link.pose.p.clone()
        grip[:, 2] = task.rope_config.radius
        p, q = DrivenSolver.scissor_pose(grip, rope.segment_yaw(link.pose.q), around=toward * np.pi / 2)
        s.set_ee("right_hand", "scissor_open", steps=0)
        s.set_ee("left_hand", "scissor_open", steps=0)
        # the left hand waits high above the far side, facing the ring
        wait = centre.clone()
        wait[:, 1] += toward * WAIT_ASIDE  # clear of the feeding hand's fingers
        wait[:, 2] = WAIT_Z
        lp, lq = DrivenSolver.scissor_pose(wait, -feed_yaw, mirror=True, around=-toward * np.pi / 2)
        s.arm_targets["left_arm"] = (lp, lq)
        s.move({"right_arm": (s.above(p, APPROACH_HEIGHT), q)}, max_steps=60)
        s.move({"right_arm": (p, q)}, max_steps=40, pos_tol=0.003)
        s.close_hand("right_hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        # lift the pinched capsule to the feed height, line it up with the ring's axis, turn along it
        start = centre.clone()
        start[:, 1] += -toward * (FEED_STOP + RUN_UP)
        start[:, 2] += FEED_LIFT
        fp, fq = DrivenSolver.scissor_pose(start, feed_yaw, around=toward * np.pi / 2)
        up = p.clone()
        up[:, 2] = fp[:, 2]
        glide(s, {"right_arm": (p, up, q)}, step_length=STEP, settle_steps=LIFT_SETTLE_STEPS)
        glide(s, {"right_arm": (up, fp, fq)}, step_length=STEP, settle_steps=FEED_SETTLE_STEPS)
        stop = start.clone()
        stop[:, 1] = centre[:, 1] - toward * FEED_STOP
        sp, _ = DrivenSolver.scissor_pose(stop, feed_yaw, around=toward * np.pi / 2)
        glide(s, {"right_arm": (fp, sp, fq)}, step_length=STEP, settle_steps=FEED_SETTLE_STEPS)
        # lay the rope on the ring's bottom and let go; the right hand backs off upwards
        rest = stop.clone()
        rest[:, 2] = REST_Z
        rp, _ = DrivenSolver.scissor_pose(rest, feed_yaw, around=toward * np.pi / 2)
        glide(s, {"right_arm": (sp, rp, fq)}, step_length=STEP, settle_steps=LIFT_SETTLE_STEPS)
        s.set_ee("right_hand", "scissor_open", steps=OPEN_STEPS)
        back = rp.clone()
        back[:, 1] -= toward * BACK_OFF_AWAY
        back[:, 2] += BACK_OFF_UP
        s.arm_targets["right_arm"] = (back, fq)
        # the left hand pinches the protruding end where it lies
        end = task.rope.links[TAKE_CAPSULE]
        tp, tq = DrivenSolver.scissor_pose(end.pose.p.clone(), rope.segment_yaw(end.pose.q), mirror=True,
                                           around=-toward * np.pi / 2)
        s.move({"left_arm": (s.above(tp, TAKE_APPROACH), tq)}, max_steps=30, pos_tol=0.01)
        s.move({"left_arm": (tp, tq)}, max_steps=30, pos_tol=0.003)
        s.close_hand("left_hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        pull = tp.clone()
        pull[:, 1] += toward * PULL
        pull[:, 2] = torch.maximum(tp[:, 2], centre[:, 2] + SCISSOR_OFFSET[2] - PULL_BELOW_CENTRE)
        glide(s, {"left_arm": (tp, pull, tq)}, step_length=STEP, settle_steps=LIFT_SETTLE_STEPS)
        down = pull.clone()
        down[:, 2] = task.rope_config.radius + SCISSOR_OFFSET[2] + LAY_DOWN_CLEARANCE
        glide(s, {"left_arm": (pull, down, tq)}, step_length=STEP, settle_steps=LIFT_SETTLE_STEPS)
        s.set_ee("left_hand", "scissor_open", steps=OPEN_STEPS)
        s.move({"left_arm": (s.above(down, LEFT_RETREAT), tq)}, max_steps=15, pos_tol=0.02)
        s.hold_until_success()
        return s.info
