"""The clip tasks' shared phases (CableIntoClipHand, RouteCableClipsHand): the LEAP hand scissor-pinches one of
the cable's capsules, carries it over a clip's slot turned onto the slot's axis, lets it go just above the walls
(`lay_over_clip`, servoing the pinched capsule: `servo_capsule`), then presses it home with the closed fingers
(`press_home`). `task` is a `RopeTask` (its `rope`, `rope_config`); `clip` a clip (`objects.clip.build_clip`).
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import rope
from maniladder_ms.objects.clip import CLIP_FLOOR
from maniladder_ms.objects.tabletop import Channel
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS

CARRY_LIFT = 0.03  # the pinched capsule's bottom this far above the walls' top while the cable is carried
LIFT_STEPS = 10  # 3 mm a control step off the table
RELEASE_ABOVE_TOP = -0.002  # the pinched capsule's bottom this far above the walls' top when let go (below: in the slot;
# the tips' ends lie 3 mm above the capsule's bottom, so they stop 1 mm above the walls)
RELEASE_STEPS = 10
RELEASE_HOLD_STEPS = 5  # control steps the opened fingers hold before the press
PRESS_RISE = 0.02  # the open fingers rise this much off the released cable before closing to press
TIP_END_ABOVE_BOTTOM = 0.003  # in the scissor pose the tips' ends lie this far above the pinched capsule's bottom
PRESS_DEPTH = 0.004  # the closed fingertips' ends this far below the seated cable's top
PRESS_STEPS = 10
PRESS_TAPS = (0.018, -0.018, 0.0)  # after the middle, press again this far along the slot's axis: over each
# neighbour, then over the middle again
TAP_LIFT = 0.012  # the fingers rise this much between presses
TAP_STEPS = 5  # control steps to rise and move over, and again to press down
PRESS_CLOSE_STEPS = 5  # control steps to swing the fingers together for the press
PRESS_SETTLE_STEPS = 5  # control steps held after the last tap
CARRY_SERVO_STEPS = 20  # control steps servoing the pinched capsule over the slot's centre before lowering
LOWER_SERVO_STEPS = 25  # control steps lowering it onto the release height, still servoing
SERVO_GAIN = 0.3
SERVO_MAX_TURN = 0.3  # rad: the yaw correction's bound
CARRY_MOVE_STEPS = 60  # control steps at most for the carry over the slot
WRIST_STALL = 0.5  # rad: the hand this far from its yaw over the capsule after the approach move stopped at the
# wrist's joint limit (RouteCableClipsHand seed 108, last clip: 1.30 rad short, joint 7 at -2.90 of its -2.90)


def scissor_pinch(s: DrivenSolver, task, segment: int, turn: float = 0.0, flip_stalled_wrist: bool = False):
    """Scissor-pinch capsule `segment` where it lies (fingers along the cable, or turned `turn` rad off it): open,
    come down over it, close. Of the two hand yaws along the fingers the one nearest 0 (`scissor_pose`) or, with
    `flip_stalled_wrist`, the other one if the hand stopped `WRIST_STALL` short of the first above the capsule (the
    wrist at its joint limit). Returns the capsule's centre at table height, the yaw the fingers lay along (the
    capsule's, plus `turn`), the TCP target (p, q) the fingers closed at and the hand yaw's `around` (0 or pi)."""
    link = task.rope.links[segment]
    centre = link.pose.p.clone()
    centre[:, 2] = task.rope_config.radius
    yaw = rope.segment_yaw(link.pose.q) + turn
    around = 0.0
    tcp, q = DrivenSolver.scissor_pose(centre, yaw)
    s.set_ee("hand", "scissor_open", steps=1)
    s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
    if flip_stalled_wrist and float(quat_angle(s.tcp("arm").q, q).max()) > WRIST_STALL:
        around = np.pi
        tcp, q = DrivenSolver.scissor_pose(centre, yaw, around=around)
        s.move({"arm": (s.above(tcp, APPROACH_HEIGHT), q)}, max_steps=60)
    s.move({"arm": (tcp, q)}, max_steps=40, pos_tol=0.003)
    s.close_hand("hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
    return centre, yaw, tcp, q, around


def quat_angle(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """The rotation angle between unit quaternions `a` and `b` (n, 4), radians."""
    return 2 * torch.acos((a * b).sum(dim=1).abs().clamp(max=1.0))


def lay_over_clip(s: DrivenSolver, task, clip: Channel, segment: int, turn: float = 0.0):
    """Scissor-pinch capsule `segment` (`scissor_pinch`, the fingers turned `turn` off it), lift it `CARRY_LIFT`
    over the clip's walls, carry it over the slot's centre while turning it onto the slot's axis, lower it until
    its bottom is `RELEASE_ABOVE_TOP` above the walls and open the fingers (`lay_on_slot`)."""
    radius = task.rope_config.radius
    _, yaw, tcp, q, _ = scissor_pinch(s, task, segment, turn)
    carry = clip.top + CARRY_LIFT + radius  # the pinched capsule's centre height while carried
    for k in range(1, LIFT_STEPS + 1):
        s.step({"arm": (s.above(tcp, (carry - radius) * k / LIFT_STEPS), q)})
    return lay_on_slot(s, task, clip, segment, along_slot(yaw, clip), carry, CARRY_MOVE_STEPS)


def along_slot(yaw: torch.Tensor, clip: Channel, around: float = 0.0) -> torch.Tensor:
    """The hand yaw that lays a capsule pinched at `yaw` along `clip`'s slot: the fingers are symmetric, so of the
    two hand yaws along the axis take the one nearest the hand's own (turn the short way: at most a quarter turn;
    measured from the capsule's `yaw` instead of the hand's, the hand turned half way round on some seeds and the
    cable twisted off the axis in the pinch). `around`: the one `scissor_pose` chose the hand's yaw near."""
    hand_yaw = DrivenSolver.neutral_yaw(yaw - around, np.pi) + around  # scissor_pose's
    return hand_yaw + DrivenSolver.neutral_yaw(clip.axis() - hand_yaw, np.pi)


def lay_on_slot(s: DrivenSolver, task, clip: Channel, segment: int, along: torch.Tensor, height, move_steps: int,
                before_release=None):
    """Move the pinched capsule `segment` over `clip`'s slot centre at centre height `height` with the hand yaw
    `along` (`along_slot`), servo it there, lower it until its bottom is `RELEASE_ABOVE_TOP` above the walls,
    run `before_release(low, q)` (returns the TCP target it reached) if given, and open the fingers. Returns the TCP
    target (p, q) where it let go, for the press."""
    radius = task.rope_config.radius
    link = task.rope.links[segment]
    slot = clip.pose.p.clone()
    slot[:, 2] = height
    s.move({"arm": DrivenSolver.scissor_pose(slot, along, around=along)}, max_steps=move_steps, pos_tol=0.004,
           rot_tol=0.03)
    servo_capsule(s, link, slot, along, CARRY_SERVO_STEPS)
    slot[:, 2] = clip.top + RELEASE_ABOVE_TOP + radius
    low, q_low = servo_capsule(s, link, slot, along, LOWER_SERVO_STEPS, descend=True)
    if before_release is not None:
        low = before_release(low, q_low)
    s.close_hand("hand", "scissor_open", ramp_steps=RELEASE_STEPS, hold_steps=RELEASE_HOLD_STEPS)
    return low, q_low


def servo_capsule(s: DrivenSolver, link, goal: torch.Tensor, along: torch.Tensor, steps: int, descend: bool = False):
    """Servo the pinched capsule `link` (not the hand: the cable dragging over the table shifts and turns it in the
    pinch by up to 2 cm and several degrees) onto `goal` (n, 3) and the hand yaw `along`: every control step
    the TCP target moves by `SERVO_GAIN` of the capsule's remaining error in xy and yaw; `descend`: the target
    height ramps from where the capsule is to the goal's over the steps. Returns the last TCP target (p, q)."""
    corr, yaw_corr = torch.zeros_like(goal), torch.zeros_like(along)
    start_z = link.pose.p[:, 2].clone()
    for k in range(1, steps + 1):
        p = link.pose.p
        err = (goal - p) * torch.tensor([1.0, 1.0, 0.0], device=p.device)
        yaw_err = DrivenSolver.neutral_yaw(along - rope.segment_yaw(link.pose.q), np.pi)
        corr = corr + SERVO_GAIN * err
        yaw_corr = (yaw_corr + SERVO_GAIN * yaw_err).clamp(-SERVO_MAX_TURN, SERVO_MAX_TURN)
        target = goal + corr
        if descend:
            target[:, 2] = start_z + (goal[:, 2] - start_z) * min(1.0, k / (steps - 5))
        tcp, q = DrivenSolver.scissor_pose(target, along + yaw_corr, around=along)
        s.step({"arm": (tcp, q)})
    return tcp, q


def press_home(s: DrivenSolver, task, clip: Channel, low: torch.Tensor, q: torch.Tensor):
    """Rise `PRESS_RISE`, swing the two fingers together and lower them onto the cable in the slot, their ends
    `PRESS_DEPTH` below the seated cable's top; hold, then withdraw upwards."""
    s.move({"arm": (s.above(low, PRESS_RISE), q)}, max_steps=15)
    s.close_hand("hand", "scissor", ramp_steps=PRESS_CLOSE_STEPS, hold_steps=0)
    # with the cable seated its centre lies at the slot's floor + radius; in the scissor pose the tips' ends
    # lie radius - TIP_END_ABOVE_BOTTOM below the pinched capsule's centre, so this target puts them PRESS_DEPTH
    # into the cable's top
    radius = task.rope_config.radius
    seated_top = CLIP_FLOOR + 2 * radius
    press = low.clone()
    press[:, 2] += (seated_top - PRESS_DEPTH) - (clip.top + RELEASE_ABOVE_TOP + TIP_END_ABOVE_BOTTOM)
    for k in range(1, PRESS_STEPS + 1):
        s.step({"arm": (s.above(low, PRESS_RISE) + (press - s.above(low, PRESS_RISE)) * k / PRESS_STEPS, q)})
    # then lift the fingers a little and press again over each neighbour (`PRESS_TAPS` along the slot's axis):
    # a neighbour left propped on the other or on a wall's edge is pushed home too (sliding the pressed
    # fingers instead dragged the cable along the slot by up to 2 cm)
    axis = clip.axis()
    along = torch.stack([torch.cos(axis), torch.sin(axis), torch.zeros_like(axis)], dim=1)
    here = press
    for offset in PRESS_TAPS:
        there = press + along * offset
        for k in range(1, TAP_STEPS + 1):  # up and over, then down
            s.step({"arm": (s.above(here + (there - here) * k / TAP_STEPS, TAP_LIFT), q)})
        for k in range(1, TAP_STEPS + 1):
            s.step({"arm": (s.above(there, TAP_LIFT * (1 - k / TAP_STEPS)), q)})
        here = there
    for _ in range(PRESS_SETTLE_STEPS):
        s.step()
    s.move({"arm": (s.above(low, APPROACH_HEIGHT / 2), q)}, max_steps=20)
