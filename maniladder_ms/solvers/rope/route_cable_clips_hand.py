"""Scripted solver of RouteCableClipsHand (tasks/rope/route_cable_clips_hand.py): clip by clip, in order, the LEAP
hand scissor-pinches the capsule of the cable that goes into that clip, carries it over the clip's slot turned onto
the slot's axis, lets it go just above the walls and presses it home with the closed fingers (CableIntoClipHand's
phases, `solvers/rope/clip_phases.py`).

1. `pick_capsule`: the capsule to pinch for the next clip: counted from the cable's end beside the first clip,
   `FIRST_CAPSULE` for the first clip and `CAPSULE_STEP` more for each next one; of it and its neighbours
   (`PICK_SHIFTS`) the first whose spread fingertips land clear of every clip (`pinch_is_clear`); if none does,
   the first whose fingertips land clear with the fingers turned off the cable by one of `PINCH_TURNS`.
2. The first clip: `lay_over_clip` (pinch, lift 3 cm over the walls, carry onto the slot, servo, lower, let go).
   Each next clip: `lay_low_over_clip` (pinch, carry the capsule low over the table to beside the slot, rise just
   over the walls onto the slot, servo, lower; `pull_slack` along the slot away from the clip before; let go): the
   cable leaves the clip before level instead of rising from its slot to the carried capsule.
   Then `press_home` (close the fingers, press the cable home, tap its neighbours, withdraw) and `seat`: the clip
   pressed again while it holds fewer than the rule's capsules.
3. `press_again`: each clip left holding fewer than the rule's capsules (the cable carried to the next clip pulls
   some of the last one's up onto its walls) is pressed again, up to `REPRESS_ROUNDS` times.
4. Hold still until success.
"""

from __future__ import annotations

import torch

from maniladder_ms.deformables import metrics, rope
from maniladder_ms.objects.clip import CLIP_WALL
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.rope.clip_phases import (RELEASE_ABOVE_TOP, along_slot, lay_on_slot, lay_over_clip,
                                                    press_home, scissor_pinch)

FIRST_CAPSULE = 2  # the capsule pressed into the first clip, counted from the cable's end beside that clip
CAPSULE_STEP = 6  # capsules between those pressed into consecutive clips: 12 cm of cable for the clips' 10 cm
# spacing (with the low carry and `pull_slack`, seeds 100-107: 5/8 against 4/8 at 7, whose 4 cm of slack crossed the
# near wall at the slot's entry; `pick_capsule` still shifts the pinch onwards where the fingertips would land on a
# clip)
MIN_STEP = 6  # never fewer capsules between consecutive clips' capsules: 12 cm of cable for 10 cm
PICK_SHIFTS = (0, 1, -1, 2)  # capsules tried after the nominal one, in this order
PINCH_TURNS = (0.4, -0.4, 0.8, -0.8)  # rad: where no capsule's pinch along the cable is clear, the fingers turned
# this far off the cable, in this order (their spread then points partly along the clip instead of onto it; seeds
# 108 and 110, middle clip, every capsule 6-10 blocked: the middle tip stopped on the clip's wall 10 mm high and
# the pinch held nothing; turned -0.8 and -0.4 the pinches of capsules 10 and 9 held)
TIP_REACH = 0.06  # the spread fingertips reach this far sideways of the pinched capsule's centre (seeds 100-103: the
# middle tip landed on a clip wall with the capsule 5.0-6.6 cm from that clip's axis, never at 8.6 cm or more)
TIP_HALF_WIDTH = 0.015  # and this far along the cable
TIP_CLEARANCE = 0.005  # kept from a clip's outline
TIP_SAMPLES = 7  # points sampled across the fingertips' span
REPRESS_ROUNDS = 2  # passes over the clips pressing again those not full
SEAT_ROUNDS = 2  # presses again of a clip left short by its own press, before the next clip
LOW_LIFT = 0.005  # the pinched capsule's bottom this far above the table while it is carried beside the clip
STAGE_OFFSET = 0.07  # where the low carry ends: this far beside the slot's axis, on the capsule's side (the pinch's
# fingertips reach `TIP_REACH` across the slot: they stay clear of the near wall)
OVER_WALL = 0.008  # then the capsule's bottom rises this far above the walls' top and moves over the slot
LOW_STEPS = 10  # control steps of each rise
OVER_SLOT_STEPS = 40  # control steps at most for the move from beside the slot over its centre
PULL_STEP = 0.002  # before letting go, the pinched capsule is pulled along the slot away from the clip before by
# this much a control step
PULL_MAX = 0.04  # and at most this far: past the slot's end (its half length is 3 cm) by 1 cm, the three capsules
# behind the pinched one inside (seeds 101, 107, 112, 119, failures at 2.4 cm, whose pull ran its whole length with
# the entry-side neighbours left on the near wall's top: 3/4 at 4 cm)
PULL_NEIGHBOURS = 2  # until this many of its neighbours towards the clip before lie between the walls


def pinch_is_clear(task, k: int, turn: float = 0.0) -> bool:
    """Whether the spread fingertips pinching capsule `k` (the fingers turned `turn` off it) land clear of every
    clip: sample points across the tips' span (`TIP_REACH` each side of the capsule, `TIP_HALF_WIDTH` along it),
    none within `TIP_CLEARANCE` of a clip's outline (its walls' outer faces and its ends), seen from above."""
    link = task.rope.links[k]
    p, yaw = link.pose.p[:, :2], rope.segment_yaw(link.pose.q) + turn
    along = torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=1)
    side = torch.stack([-torch.sin(yaw), torch.cos(yaw)], dim=1)
    offsets = torch.linspace(-TIP_REACH, TIP_REACH, TIP_SAMPLES)
    pts = [p + o * side + w * along for o in offsets for w in (-TIP_HALF_WIDTH, 0.0, TIP_HALF_WIDTH)]
    pts = torch.stack(pts, dim=1)  # [B, S, 2]
    for clip in task.clips:
        a, x = metrics.channel_coords(pts, clip.pose.p, clip.axis())
        outer = clip.half_width + CLIP_WALL + TIP_CLEARANCE
        if bool(((a.abs() <= clip.half_length + TIP_CLEARANCE) & (x.abs() <= outer)).any()):
            return False
    return True


def pick_capsule(task, nominal: int, previous: int | None, direction: int) -> tuple[int, float]:
    """The capsule to pinch for the next clip and the fingers' turn off it: `nominal` or, if its pinch is not
    clear, the first of its neighbours (`PICK_SHIFTS`, along `direction`: +1 counting up from capsule 0, -1 down)
    that is, keeping at least `MIN_STEP` capsules after `previous`; if none is, the first of them whose pinch
    turned by one of `PINCH_TURNS` is; `nominal` unturned if none is."""
    last = task.rope_config.segments - 2  # the clip's 3 capsules must exist: the pick's neighbours too
    ks = [nominal + direction * shift for shift in PICK_SHIFTS]
    ks = [k for k in ks if 1 <= k <= last and (previous is None or direction * (k - previous) >= MIN_STEP)]
    for turn in (0.0,) + PINCH_TURNS:
        for k in ks:
            if pinch_is_clear(task, k, turn):
                return k, turn
    return nominal, 0.0


def first_end_direction(task) -> int:
    """+1 when the cable's capsule 0 lies nearer the first clip than its last capsule (count up), else -1."""
    centres = task.rope.points()[:, 1:-1]
    first_clip = task.clips[0].pose.p
    near0 = torch.linalg.norm(centres[:, 0, :2] - first_clip[:, :2], dim=1)
    near1 = torch.linalg.norm(centres[:, -1, :2] - first_clip[:, :2], dim=1)
    return 1 if bool((near0 <= near1)[0]) else -1


def lay_low_over_clip(s: DrivenSolver, task, clip, segment: int, previous_clip, direction: int, turn: float = 0.0):
    """Scissor-pinch capsule `segment`, carry it `LOW_LIFT` over the table to `STAGE_OFFSET` beside the clip's
    slot, turned onto the slot's axis, rise until its bottom is `OVER_WALL` above the walls, move over the slot's
    centre, servo, lower it until its bottom is `RELEASE_ABOVE_TOP` above the walls, `pull_slack` and open the
    fingers: the cable behind it leaves `previous_clip`'s slot level (carried 3 cm over the walls, as
    `lay_over_clip` does, it rose 4 cm from that slot's exit to the carried capsule and pulled that clip's capsules
    up out of it). The pinch and the lay over the slot are `lay_over_clip`'s (`scissor_pinch`, `lay_on_slot`); the
    pinch takes the hand's other yaw where the wrist stalls at its joint limit above the capsule
    (`flip_stalled_wrist`: seed 108, last clip, the hand 1.3 rad short, its index tip landed on the cable).
    Returns the TCP target (p, q) where it let go, for the press."""
    radius = task.rope_config.radius
    centre, yaw, tcp, q, around = scissor_pinch(s, task, segment, turn, flip_stalled_wrist=True)
    for k in range(1, LOW_STEPS + 1):
        s.step({"arm": (s.above(tcp, LOW_LIFT * k / LOW_STEPS), q)})
    axis = clip.axis()
    along = along_slot(yaw, clip, around)
    across = torch.stack([-torch.sin(axis), torch.cos(axis), torch.zeros_like(axis)], dim=1)
    side = torch.sign(((centre - clip.pose.p) * across).sum(dim=1, keepdim=True))
    stage = clip.pose.p + side * STAGE_OFFSET * across
    stage[:, 2] = radius + LOW_LIFT
    s.move({"arm": DrivenSolver.scissor_pose(stage, along, around=along)}, max_steps=60, pos_tol=0.004, rot_tol=0.03)
    over = clip.top + OVER_WALL + radius
    for k in range(1, LOW_STEPS + 1):
        stage[:, 2] = radius + LOW_LIFT + (over - radius - LOW_LIFT) * k / LOW_STEPS
        s.step({"arm": DrivenSolver.scissor_pose(stage, along, around=along)})
    return lay_on_slot(s, task, clip, segment, along, over, OVER_SLOT_STEPS,
                       before_release=lambda low, q_low: pull_slack(s, task, clip, segment, previous_clip, direction,
                                                                    low, q_low))


def pull_slack(s: DrivenSolver, task, clip, segment: int, previous_clip, direction: int, tcp, q):
    """Pull the pinched capsule `segment` along `clip`'s slot away from `previous_clip`, `PULL_STEP` a control
    step up to `PULL_MAX`, until its `PULL_NEIGHBOURS` neighbours towards that clip (capsules segment - direction,
    ...) lie between the walls: the cable's slack between the clips otherwise crosses the near wall at the slot's
    entry and its capsules rest on the wall's top. The pull stops as soon as `previous_clip` holds fewer capsules
    than the rule's and than when the pull began: pulled on, the cable slides lengthwise out of that clip.
    Returns the TCP target reached."""
    previous = next(i for i, c in enumerate(task.clips) if c is previous_clip)
    keep = min(float(task.inside_counts()[0, previous]), task.min_segments)
    axis = clip.axis()
    unit = torch.stack([torch.cos(axis), torch.sin(axis), torch.zeros_like(axis)], dim=1)
    away = torch.sign(((clip.pose.p - previous_clip.pose.p) * unit).sum(dim=1, keepdim=True))
    neighbours = [segment - direction * i for i in range(1, PULL_NEIGHBOURS + 1)]
    target = tcp.clone()
    for _ in range(round(PULL_MAX / PULL_STEP)):
        centres = torch.stack([task.rope.links[k].pose.p[:, :2] for k in neighbours], dim=1)
        _, across = metrics.channel_coords(centres, clip.pose.p, axis)
        if bool((across.abs() < clip.half_width).all()) or float(task.inside_counts()[0, previous]) < keep:
            break
        target = target + away * unit * PULL_STEP
        s.step({"arm": (target, q)})
    return target


def press_clip(s: DrivenSolver, task, clip):
    """`press_home` on `clip` from the TCP pose that would have let a pinched capsule go over its slot's middle."""
    slot = clip.pose.p.clone()
    slot[:, 2] = clip.top + RELEASE_ABOVE_TOP + task.rope_config.radius
    along = DrivenSolver.neutral_yaw(clip.axis(), torch.pi)
    low, q = DrivenSolver.scissor_pose(slot, along, around=along)
    press_home(s, task, clip, low, q)


def seat(s: DrivenSolver, task, i: int):
    """Press clip `i` again, up to `SEAT_ROUNDS` times, while it holds fewer than `min_segments` capsules: the next
    clip filled before this one is entered breaks the order for good (the end's `press_again` comes too late)."""
    for _ in range(SEAT_ROUNDS):
        if float(task.inside_counts()[0, i]) >= task.min_segments:
            return
        press_clip(s, task, task.clips[i])


def press_again(s: DrivenSolver, task):
    """Press again each clip holding fewer than `min_segments` capsules (first to last, `REPRESS_ROUNDS` passes)."""
    for _ in range(REPRESS_ROUNDS):
        counts = task.inside_counts()[0]
        short = [clip for clip, n in zip(task.clips, counts.tolist()) if n < task.min_segments]
        if not short:
            return
        for clip in short:
            press_clip(s, task, clip)


@register_solver("RouteCableClipsHand", control_modes=TCP_DELTA_MODES)
def solve_route_cable_clips_hand(env, seed: int) -> dict:
    """For each clip in order `pick_capsule`, `lay_over_clip` (the first) or `lay_low_over_clip`, `press_home`,
    `seat`; then `press_again` and hold still until success."""
    with DrivenSolver.episode(env, seed) as s:
        task = env.unwrapped
        direction = first_end_direction(task)
        start = FIRST_CAPSULE if direction > 0 else task.rope_config.segments - 1 - FIRST_CAPSULE
        previous = None
        for i, clip in enumerate(task.clips):
            nominal = start if previous is None else previous + direction * CAPSULE_STEP
            k, turn = pick_capsule(task, nominal, previous, direction)
            if i == 0:  # no clip before it; carried low, the cable's free end caught the near wall (seed 104)
                low, q = lay_over_clip(s, task, clip, k, turn)
            else:
                low, q = lay_low_over_clip(s, task, clip, k, task.clips[i - 1], direction, turn)
            press_home(s, task, clip, low, q)
            seat(s, task, i)
            previous = k
        press_again(s, task)
        s.hold_until_success()
        return s.info
