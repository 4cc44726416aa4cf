"""Scripted solver of HandoverMugHands (tasks/rigid/handover/handover_mug_hands.py): the left hand picks the
upside-down mug and rolls palm-up so that the mug turns upright in its fingers; the right hand takes the mug's upper
part top-down, carries it over the coaster, sets it down and lets go.

1. Pick and roll: the right waits top-down aside (TAKER_WAIT); the left picks the mug top-down at
   GIVER_TCP_HEIGHT, its finger row along the handle, and rolls palm-up on the way to MEET (`pick_and_roll`).
2. Take: the right closes "power" round the mug's upper part (TAKER_DEPTH below the rim), its fingers at a yaw
   chosen from the handle's direction at the meet (TAKER_YAW or TAKER_YAW_TURNED, `take`).
3. Swap: the left opens as the right lifts the mug off its fingers, then moves aside, level (`swap`).
4. Carry: the right straightens the mug in its grip, carries it level over the coaster (aimed PLACE_BIAS short of
   its centre), lowers it, straightens it again and presses it onto the coaster (`carry_to_coaster`).
5. Let go: the digits straighten at their outer joints, the hand turns square over the mug, the knuckles open, the
   hand rises (`let_go`).
6. Regrasp: a released mug standing upright more than REGRASP_FROM off the coaster's centre is taken again square
   from above (`solvers.mug.mug_to_coaster`).
7. Nudge: a released mug more than NUDGE_FROM off the centre is pushed there by the index tip (`nudge`, NUDGES times).

The measurements behind the numbers, and what was tried: docs/tasks/HandoverMugHands.md.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply, quaternion_multiply

from maniladder_ms.agents.effectors import leap_fingertip

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import tilt, uprighting
from maniladder_ms.objects.mug import COASTER_HEIGHT
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, HandoverSolver, glide, reach, roll_targets
from maniladder_ms.solvers.mug import mug_to_coaster
from maniladder_ms.tasks.rigid.handover.handover_mug_hands import UPSIDE_DOWN, HandoverMugHandsEnv

# 1. pick and roll
GIVER_TCP_HEIGHT = 0.065  # the giver's top-down TCP above the table at the pick (the upside-down mug's base at 9 cm)
GIVER_LIFT = 0.15  # metres the giver lifts the mug before it rolls
GIVER_ROLL_SIGN = -1.0  # about the TCP y axis (the finger row, world x): the left Panda's joint 7 stays mid-range
GIVER_ROLL_WAYPOINTS, GIVER_ROLL_STEPS = 12, 8
MEET = (-0.08, 0.02, 0.3)  # the giver's TCP at the end of the roll
TAKER_WAIT = (0.0, -0.2, 0.15)  # from MEET, where the right waits top-down during the pick and roll
# 2. take: the taker's fingers curl round the mug at TAKER_YAW (world), its thumb opposite: -pi/4 puts them between
# the handle (+x) and the giver's fingertips (-y), the thumb between the giver's thumb (+y) and the robot (-x)
TAKER_YAW = -np.pi / 4
# ... or at TAKER_YAW_TURNED where the mug's handle points further round than HANDLE_TURNED at the meet (it points
# -2 to -48 deg there): at -45 deg the taker's close tips a mug whose handle points -2 to -15 deg, at -15 deg it
# loses mugs whose handle points -25 to -43 deg. The threshold was fitted on seeds 100-149 (docs/tasks/)
TAKER_YAW_TURNED = np.deg2rad(-15.0)
HANDLE_TURNED = np.deg2rad(-20.0)
TAKER_DEPTH = 0.045  # the taker's TCP this far below the rim
TAKER_ASIDE = 0.025  # the taker lines up this far towards its thumb (against TAKER_YAW): the thumb clears the rim
TAKER_APPROACH = 0.1  # ... and comes down the last this far onto its grasp
TAKER_CLOSE_STEPS = 80  # the taker closes over this many steps (40, as DrivenSolver.grasp, tipped the mug 30-80 deg)
# 3. swap
TAKER_LIFT = 0.05  # the taker lifts the mug this far off the giver's fingers as the giver opens
GIVER_OPEN_STEPS = 10  # the giver's fingers open clear of the mug before it moves
GIVER_RETREAT = (0.0, 0.15, 0.0)  # then it moves aside, level: its open fingers reach ~15 cm towards -y
# 4. carry
CARRY_STEP = 0.006  # metres a control step while the taker carries the mug
# let_go pushes the standing mug +1.5-2.5 cm along world x (seeds 100-109): set it down this far towards -x of the
# coaster's centre
PLACE_BIAS = 0.035
PLACE_ABOVE = 0.03  # the tilt is corrected again with the mug's bottom this far above the coaster
PLACE_AIMS = 2  # closed-loop moves putting the mug's bottom centre over its target, PLACE_ABOVE up
PLACE_PUSH = 0.01  # the hand's target: the mug's bottom this far into the coaster (pressed onto it while opening)
# 5. let go
RELEASE_STEPS = 20  # the taker's outer joints, then its knuckles, straighten over this many steps each
OUTER_JOINTS = [2, 3, 6, 7, 10, 11, 13, 14, 15]  # the fingers' PIP / DIP and the thumb's bends (LEAP joint order)
KNUCKLE_JOINTS = [0, 1, 4, 5, 8, 9]  # the fingers' side and MCP joints (the thumb's swing, 12, last)
SQUARE_STEPS = 30  # control steps the loosened hand takes to turn square over the standing mug (let_go)
SQUARE_MAX_TILT = 5.0  # degrees: ... only while the mug stands within this of upright
SQUARE_MAX_TURN = 35.0  # degrees: ... and the hand is no further than this from square
RELEASE_RISE = 0.1  # metres the open hand rises off the mug
# 6. regrasp
REGRASP_FROM = 0.02  # m: a released mug standing further than this from the coaster's centre is taken again
# 7. nudge
NUDGES = 2  # closed-loop pushes of the released mug towards the coaster's centre (nudge)
NUDGE_FROM = 0.01  # ... when it stands further than this from it
NUDGE_HEIGHT = 0.035  # the index tip's height above the table while it pushes
NUDGE_GAP = 0.03  # the tip comes down this far out from the mug's side
NUDGE_TIP = 0.015  # the pointing index finger's half width: its tip centre this far from the mug's side at contact
NUDGE_HANDLE_CLEAR = 40.0  # degrees: the tip comes down at least this far round the mug from its handle
NUDGE_TIP_BEARING = 0.42  # rad: the "point" index tip's bearing from the TCP of a top-down hand of yaw 0 (measured)
NUDGE_SHORT = 0.003  # the push stops this short of the centre (the mug slides on a little)
NUDGE_STEP = 0.0015  # metres a control step while pushing
NUDGE_OVER = 0.04  # the tip comes and goes this far above the mug's height


@register_solver("HandoverMugHands", control_modes=TCP_DELTA_MODES)
def solve_handover_mug_hands(env, seed: int) -> dict:
    """Phases 1-7 of the module docstring."""
    with HandoverSolver.episode(env, seed) as s:
        task: HandoverMugHandsEnv = env.unwrapped
        pick_and_roll(s, task)
        taker_q = take(s, task)
        swap(s, task, taker_q)
        taker_q = carry_to_coaster(s, task)
        let_go(s, task, taker_q)
        if regrasp_needed(task):  # standing upright off the coaster: take it again square from above
            mug_to_coaster(s, task, "right_arm", "right_hand")
        for _ in range(NUDGES):
            nudge(s, task)
        s.hold_until_success()
        return s.info


def handle_direction(task: HandoverMugHandsEnv) -> torch.Tensor:
    """The world direction (num_envs, 3) the mug's handle points to (the mug's -x)."""
    minus_x = torch.tensor([[-1.0, 0.0, 0.0]], device=task.device).expand(task.num_envs, 3)
    return quaternion_apply(task.mug.pose.q, minus_x)


def pick_and_roll(s: HandoverSolver, task: HandoverMugHandsEnv):
    """The right waits aside; the left picks the mug top-down, the finger row along the handle, and rolls palm-up
    on the way to MEET (the mug turns upright in its fingers)."""
    dev, n = task.device, task.num_envs
    meet = torch.tensor([MEET], device=dev).expand(n, 3)
    s.arm_targets["right_arm"] = (meet + torch.tensor(TAKER_WAIT, device=dev), top_down_quat(TAKER_YAW, n, device=dev))
    handle = handle_direction(task)
    yaw = torch.atan2(handle[:, 1], handle[:, 0]) + np.pi / 2  # TCP y (the finger row) along the handle
    grasp = task.mug.pose.p.clone()
    grasp[:, 2] = GIVER_TCP_HEIGHT
    s.pick("left_arm", "left_hand", grasp, yaw, lift=GIVER_LIFT)
    for target in roll_targets(s, "left_arm", yaw, GIVER_ROLL_SIGN, meet, GIVER_ROLL_WAYPOINTS, GIVER_ROLL_STEPS):
        s.step(target)
    s.move({"left_arm": target["left_arm"]}, max_steps=20)


def take(s: HandoverSolver, task: HandoverMugHandsEnv) -> torch.Tensor:
    """The right, top-down over the upright mug's upper part and lined up TAKER_ASIDE towards its thumb, closes
    "power" round it at the yaw the handle's direction picks; returns the taker's TCP orientation."""
    dev, n = task.device, task.num_envs
    height = torch.tensor([[0.0, 0.0, task.mug_shape.body.height]], device=dev).expand(n, 3)
    rim = task.mug.pose.p + quaternion_apply(task.mug.pose.q, height)
    take_p = rim - torch.tensor([0.0, 0.0, TAKER_DEPTH], device=dev)
    handle = handle_direction(task)
    turned = torch.atan2(handle[:, 1], handle[:, 0]) > HANDLE_TURNED
    take_yaw = torch.where(turned, float(TAKER_YAW_TURNED), float(TAKER_YAW)).to(dev)
    taker_q = top_down_quat(take_yaw, n, device=dev)
    aside = torch.stack([-TAKER_ASIDE * torch.cos(take_yaw), -TAKER_ASIDE * torch.sin(take_yaw),
                         torch.full((n,), TAKER_APPROACH, device=dev)], dim=1)
    # (at TAKER_YAW the line-up computed in float64, float for float as measured: the swap is sensitive to it)
    aside[~turned] = torch.tensor([-TAKER_ASIDE * float(np.cos(TAKER_YAW)), -TAKER_ASIDE * float(np.sin(TAKER_YAW)),
                                   TAKER_APPROACH], device=dev)
    reach(s, [Grasp("right_arm", "right_hand", take_p, taker_q, aside)])
    s.close_hand("right_hand", "power", ramp_steps=TAKER_CLOSE_STEPS)
    return taker_q


def swap(s: HandoverSolver, task: HandoverMugHandsEnv, taker_q: torch.Tensor):
    """The giver opens while the taker lifts the mug TAKER_LIFT off its fingers, then moves aside (GIVER_RETREAT),
    level."""
    s.set_ee("left_hand", "open", steps=0)
    s.move({"right_arm": (s.above(s.tcp("right_arm").p, TAKER_LIFT), taker_q)}, max_steps=15)
    for _ in range(GIVER_OPEN_STEPS):
        s.step()
    tcp = s.tcp("left_arm")
    s.move({"left_arm": (tcp.p + torch.tensor(GIVER_RETREAT, device=task.device), tcp.q)}, max_steps=20, pos_tol=0.02)


def place_tcp(s: HandoverSolver, task: HandoverMugHandsEnv, gap: float) -> torch.Tensor:
    """The right TCP that puts the held mug's bottom centre `gap` over the coaster, PLACE_BIAS short along -x."""
    p = task.coaster.pose.p + s.tcp("right_arm").p - task.mug.pose.p
    p[:, 0] -= PLACE_BIAS
    p[:, 2] += COASTER_HEIGHT + gap
    return p


def carry_to_coaster(s: HandoverSolver, task: HandoverMugHandsEnv) -> torch.Tensor:
    """Straighten the mug in the grip, carry it level over the coaster, lower it to PLACE_ABOVE, straighten it
    again, aim it closed loop and press it PLACE_PUSH into the coaster; returns the taker's TCP orientation."""
    taker_q = uprighting(task.mug.pose.q, s.tcp("right_arm").q)
    s.move({"right_arm": (s.tcp("right_arm").p.clone(), taker_q)}, max_steps=30)
    start = s.tcp("right_arm").p.clone()
    across = place_tcp(s, task, 0.0)
    across[:, 2] = start[:, 2]
    glide(s, {"right_arm": (start, across, taker_q)}, step_length=CARRY_STEP, settle_steps=5)
    glide(s, {"right_arm": (across, place_tcp(s, task, PLACE_ABOVE), taker_q)}, step_length=CARRY_STEP, settle_steps=10)
    taker_q = uprighting(task.mug.pose.q, s.tcp("right_arm").q)
    s.move({"right_arm": (s.tcp("right_arm").p.clone(), taker_q)}, max_steps=30)
    for _ in range(PLACE_AIMS):  # closed loop on the mug's own position (it shifts in the grip on the way)
        s.move({"right_arm": (place_tcp(s, task, PLACE_ABOVE), taker_q)}, max_steps=20, pos_tol=0.002)
    glide(s, {"right_arm": (s.tcp("right_arm").p.clone(), place_tcp(s, task, -PLACE_PUSH), taker_q)},
          step_length=0.002, settle_steps=10)
    return taker_q


def let_go(s: HandoverSolver, task: HandoverMugHandsEnv, taker_q: torch.Tensor):
    """Let go of the standing mug: the arm holds where it is (its target no longer pressed into the coaster),
    the joint targets go to where the joints are (no squeeze), the digits straighten at their outer joints, then at
    their knuckles, the hand opens and rises."""
    tcp = s.tcp("right_arm")
    s.arm_targets["right_arm"] = (tcp.p.clone(), tcp.q.clone())
    hand = task.agent.controller.controllers["right_hand"].qpos.clone()
    s.close_hand("right_hand", hand, ramp_steps=5, hold_steps=3)
    hand[:, OUTER_JOINTS] = 0
    s.close_hand("right_hand", hand, ramp_steps=RELEASE_STEPS, hold_steps=3)
    # the loosened hand turns square over the mug if it still stands upright (top-down, about the TCP): opening the
    # knuckles of a hand held askew flings the mug (22 deg in the grip: flung 19 cm; squared first: released 0.7 cm
    # off); a mug already tipping in the loosened hand, or under a hand 45 deg askew, is tipped over by the turn
    # (SQUARE_MAX_TILT, SQUARE_MAX_TURN)
    tcp = s.tcp("right_arm")
    down = quaternion_apply(tcp.q, torch.tensor([[0.0, 0.0, 1.0]], device=task.device).expand(task.num_envs, 3))
    askew = torch.arccos((-down[:, 2]).clamp(-1, 1))
    if bool(((tilt(task.mug) < np.deg2rad(SQUARE_MAX_TILT)) & (askew < np.deg2rad(SQUARE_MAX_TURN))).all()):
        taker_q = uprighting(quaternion_multiply(tcp.q, torch.tensor([UPSIDE_DOWN], device=task.device)), tcp.q)
        s.move({"right_arm": (tcp.p.clone(), taker_q)}, max_steps=SQUARE_STEPS)
    hand[:, KNUCKLE_JOINTS] = 0
    s.close_hand("right_hand", hand, ramp_steps=RELEASE_STEPS, hold_steps=3)
    s.close_hand("right_hand", "open", ramp_steps=10, hold_steps=2)
    s.move({"right_arm": (s.above(s.tcp("right_arm").p.clone(), RELEASE_RISE), taker_q)}, max_steps=30, pos_tol=0.02)


def regrasp_needed(task: HandoverMugHandsEnv) -> bool:
    """The released mug stands upright but further than REGRASP_FROM from the coaster's centre."""
    off = (task.coaster.pose.p - task.mug.pose.p)[:, :2].norm(dim=1)
    return bool(((off > REGRASP_FROM) & (tilt(task.mug) < np.deg2rad(task.max_tilt))).any())


def nudge(s: HandoverSolver, task: HandoverMugHandsEnv):
    """If the released mug stands upright but more than NUDGE_FROM from the coaster's centre, push it there with the
    right index tip ("point"), the hand turned so that the tip leads (the rest of the hand, whose lowest digits hang
    within the mug's height, stays behind it): the tip comes down NUDGE_GAP out from the mug's side opposite the
    centre (turned away from the handle if the handle is there), slides along the line to the centre, backs off
    and rises."""
    mug, n, dev = task.mug.pose.p, task.num_envs, task.device
    to = (task.coaster.pose.p - mug)[:, :2]
    dist = to.norm(dim=1)
    upright = tilt(task.mug) < np.deg2rad(task.max_tilt)
    if not bool(((dist > NUDGE_FROM) & upright).any()):
        return
    d = torch.nn.functional.normalize(to, dim=1)
    heading = torch.atan2(d[:, 1], d[:, 0])
    back = heading + np.pi  # the side the tip pushes from
    handle = handle_direction(task)
    rel = back - torch.atan2(handle[:, 1], handle[:, 0])
    rel = torch.atan2(torch.sin(rel), torch.cos(rel))
    clear = np.deg2rad(NUDGE_HANDLE_CLEAR)
    back = torch.where(rel.abs() < clear, back + torch.where(rel >= 0, 1.0, -1.0) * (clear - rel.abs()), back)
    side = torch.stack([torch.cos(back), torch.sin(back)], dim=1)
    # the hand's yaw that points its TCP-to-tip offset along the push
    yaw = heading - NUDGE_TIP_BEARING
    yaw = torch.atan2(torch.sin(yaw), torch.cos(yaw))
    q = top_down_quat(yaw, n, device=dev)
    s.set_ee("right_hand", "point", steps=0)
    s.move({"right_arm": (s.tcp("right_arm").p.clone(), q)}, max_steps=60)
    tip_in_tcp = leap_fingertip(task.agent, "index", "right_") - s.tcp("right_arm").p

    def tcp_at(xy: torch.Tensor, z: float) -> torch.Tensor:
        return torch.cat([xy, torch.full((n, 1), z, device=dev)], dim=1) - tip_in_tcp

    radius = task.mug_shape.outer_radius
    start = mug[:, :2] + side * (radius + NUDGE_GAP)
    end = start + d * (NUDGE_GAP - NUDGE_TIP + dist - NUDGE_SHORT)[:, None]
    above = task.mug_shape.body.height + NUDGE_OVER
    s.move({"right_arm": (tcp_at(start, above), q)}, max_steps=40, pos_tol=0.005)
    s.move({"right_arm": (tcp_at(start, NUDGE_HEIGHT), q)}, max_steps=40, pos_tol=0.004)
    glide(s, {"right_arm": (tcp_at(start, NUDGE_HEIGHT), tcp_at(end, NUDGE_HEIGHT), q)}, step_length=NUDGE_STEP,
          settle_steps=5)
    back_off = end - d * NUDGE_GAP
    s.move({"right_arm": (tcp_at(back_off, NUDGE_HEIGHT), q)}, max_steps=15, pos_tol=0.005)
    s.move({"right_arm": (tcp_at(back_off, above), q)}, max_steps=30, pos_tol=0.01)
