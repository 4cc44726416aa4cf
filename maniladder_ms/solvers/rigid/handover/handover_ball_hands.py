"""Scripted solver of HandoverBallHands (tasks/rigid/handover/handover_ball_hands.py): the left hand picks the ball
top-down and holds it up; the right hand, rolled palm-up, comes up under it and takes it from below (the "cradle").

1. The right rolls palm-up beside the meeting point in the background (`roll_targets`) while the left picks the
   ball top-down (the "giver" posture, `solvers.postures`) and carries it to MEET.
2. The right comes up under the ball (a 4.5 mm gap, CRADLE_BALL_IN_TAKER), the last CRADLE_APPROACH straight up,
   and raises a low dish (CRADLE_DISH).
3. The left relaxes: its joint targets go to its measured joint positions (no squeeze).
4. The swap: the left opens and rises while the right closes "power" round the ball.
5. If the ball lies on the right palm with no finger on it, the right curls further (CRADLE_SQUEEZE); then hold.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_to_matrix

from maniladder_ms.solvers.control import top_down_quat

from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import HandoverSolver, glide, roll_targets
from maniladder_ms.tasks.rigid.handover.handover_ball_hands import HandoverBallHandsEnv

# palm-up by rolling in 12 waypoints of pi/12 about a TCP axis, 8 servo steps each (one 180-degree target and a
# joint-space path servoed one waypoint a step both fail to get there)
TAKER_ROLL_WAYPOINTS = 12
ROLL_STEPS = 8
GIVER_LIFT = 0.12  # metres the left lifts the ball out of its stand
# roll the right palm-up in the background while the left picks
MEET = (-0.1, 0.02, 0.36)  # left TCP during the handover: high enough for the palm-up right wrist (0.256 m below)
TAKER_ROLL_OFFSET = (0.0, -0.2, -0.12)  # where the right turns palm-up: clear of the ball and the left hand


# The giver holds the ball top-down with the "giver" posture: its contacts (index tip, middle tip, thumb tip) all sit at or
# above the ball's equator (measured in the ball frame: index +0.007, middle +0.015, thumb +0.031 m), so the lower
# hemisphere is free for a palm-up taker. The swap that works: the taker's palm comes up under the ball with a gap,
# the giver's joint targets are set to their MEASURED positions (its ~30 N squeeze drops to ~1 N with no finger
# motion, so nothing is stored to kick the ball), then in one phase the giver opens and rises while the taker closes.
# Ball on a flat palm rolls away at a ~1 degree tilt (0.1-0.3 m/s in 10-20 steps, measured), so the taker must close
# straight away, not after the giver has gone (release first, then close: 0/10; partial-open, lift, close: 2/10).
CRADLE_TAKER_YAW = -np.pi / 2  # top-down yaw the right rolls from (about its TCP y): palm-up, fingers towards +y
# the ball in the palm-up right TCP frame at the swap: 1 cm towards the thumb from the finger bases (so its +x side
# overlaps the raised ring finger, below), level with the thumb's row position, its bottom 4.5 mm above the palm
# (TCP z -0.08): a gap, so the taker's arm stores no push. (-0.02, 0, -0.042) with a flat ring: 42/50
CRADLE_BALL_IN_TAKER = (-0.01, 0.0, -0.042)
CRADLE_BELOW = 0.1  # the right first comes to this far below its take pose, hand open
CRADLE_APPROACH = 0.05  # then the last 5 cm straight up
CRADLE_APPROACH_STEP = 0.003  # ... at 3 mm a control step
# low dish once under the ball: index and middle raised 0.5 rad at the knuckle, the RING raised 1.4 rad, a post at
# the row's ring end (in 7 of the 12 failures without it the ball rolled 4-12 cm along the row, towards the ring, in
# the 20 steps after the giver let go, and off the palm or into the thumb/ring corner); thumb flat (a thumb raised
# to j12 1.0-1.6 pushes the ball 15-25 N into the giver and it flies off when the giver lets go: 1/10)
CRADLE_DISH = [0, 0.5, 0.2, 0.2] * 2 + [0, 1.4, 0.2, 0.2] + [0, 0, 0, 0]
CRADLE_TAKER_GRIP = LEAP_SYNERGIES["power"]
CRADLE_GIVER_OPEN_STEPS = 30  # the giver's targets ramp from its relaxed pose to open
CRADLE_TAKER_CLOSE_STEPS = 30  # ... while the taker ramps to its grip (20: 1/10, the fingers miss the rolled ball)
CRADLE_GIVER_RISE = 0.005  # metres a control step, from the first step of the swap, up to CRADLE_GIVER_LIFT
CRADLE_GIVER_LIFT = 0.08
CRADLE_SWAP_STEPS = 60
CRADLE_SQUEEZE = LEAP_SYNERGIES["cradle_squeeze"]
ON_PALM = 0.1  # m: the ball counts as on the right palm within this of its TCP


@register_solver("HandoverBallHands", control_modes=TCP_DELTA_MODES)
def solve_handover_ball_hands(env, seed: int) -> dict:
    """Phases 1-5 of the module docstring."""
    with HandoverSolver.episode(env, seed) as s:
        task: HandoverBallHandsEnv = env.unwrapped
        dev, n = task.device, task.num_envs
        # 1. the right rolls palm-up in the background; the left picks and carries the ball to MEET
        meet = torch.tensor([MEET], device=dev).expand(n, 3)
        aside = meet + torch.tensor(TAKER_ROLL_OFFSET, device=dev)
        s.background = roll_targets(s, "right_arm", CRADLE_TAKER_YAW, -1.0, aside, TAKER_ROLL_WAYPOINTS, ROLL_STEPS)
        s.pick("left_arm", "left_hand", task.ball.pose.p.clone(), 0.0, lift=GIVER_LIFT)
        s.move({"left_arm": (meet, top_down_quat(0.0, n, device=dev))}, max_steps=60, pos_tol=0.01)
        while s.background is not None:
            s.step()
        # 2. the right comes up under the ball and raises a low dish
        take_q = s.arm_targets["right_arm"][1]
        # right TCP from the ball: minus the ball's offset in the taker frame, turned into the world
        off = -(quaternion_to_matrix(take_q) @ torch.tensor(CRADLE_BALL_IN_TAKER, device=dev).reshape(1, 3, 1))[..., 0]
        up = torch.tensor([0.0, 0.0, 1.0], device=dev)
        s.move({"right_arm": (task.ball.pose.p + off - CRADLE_BELOW * up, take_q)}, max_steps=60, pos_tol=0.01)
        s.set_ee("right_hand", "open", steps=5)
        s.move({"right_arm": (task.ball.pose.p + off - CRADLE_APPROACH * up, take_q)}, max_steps=30, pos_tol=0.004)
        glide(s, {"right_arm": (s.tcp("right_arm").p.clone(), task.ball.pose.p + off, take_q)},
              step_length=CRADLE_APPROACH_STEP, settle_steps=10)
        s.close_hand("right_hand", CRADLE_DISH, ramp_steps=15, hold_steps=3)
        # 3. relax: the giver's targets to its measured joint positions (its squeeze ~30 N -> ~1 N, nothing moves)
        relaxed = task.agent.controller.controllers["left_hand"].qpos.clone()
        s.close_hand("left_hand", relaxed, ramp_steps=5, hold_steps=5)
        # 4. the swap
        giver0, taker0 = s.ee_cmd["left_hand"].clone(), s.ee_cmd["right_hand"].clone()
        grip = torch.as_tensor(np.asarray(CRADLE_TAKER_GRIP), dtype=torch.float32, device=dev)
        tcp = s.tcp("left_arm")
        lp, lq = tcp.p.clone(), tcp.q.clone()
        for k in range(1, CRADLE_SWAP_STEPS + 1):
            s.set_ee("left_hand", giver0 * (1 - min(k / CRADLE_GIVER_OPEN_STEPS, 1.0)), steps=0)
            s.set_ee("right_hand", taker0 + (grip - taker0) * min(k / CRADLE_TAKER_CLOSE_STEPS, 1.0), steps=0)
            s.step({"left_arm": (lp + min(k * CRADLE_GIVER_RISE, CRADLE_GIVER_LIFT) * up, lq)})
        # 5. closed loop: the ball still on the right palm but no finger on it (it rolled into the thumb / ring corner,
        # where "power" fingers pass over it), or a grasp that flickers (any step of 5 without it): curl the
        # fingers further (CRADLE_SQUEEZE)
        held = s.info["right_grasped"].clone()
        for _ in range(5):
            s.step()
            held &= s.info["right_grasped"]
        on_palm = (task.ball.pose.p - s.tcp("right_arm").p).norm(dim=1) < ON_PALM
        if bool((on_palm & ~held).any()):
            s.close_hand("right_hand", CRADLE_SQUEEZE, ramp_steps=20, hold_steps=5)
        s.hold_until_success()
        return s.info
