"""Scripted solver of RouteCableClipsHand (tasks/rope/route_cable_clips_hand.py): clip by clip, in order, the LEAP
hand scissor-pinches the capsule of the cable that goes into that clip, carries it over the clip's slot turned onto
the slot's axis, lets it go just above the walls and presses it home with the closed fingers (CableIntoClipHand's
phases, `solvers/rope/clip_phases.py`).

1. `pick_capsule`: the capsule to pinch for the next clip: counted from the cable's end beside the first clip,
   `FIRST_CAPSULE` for the first clip and `CAPSULE_STEP` more for each next one; of it and its neighbours
   (`PICK_SHIFTS`) the first whose spread fingertips land clear of every clip (`pinch_is_clear`).
2. For each clip in order: `lay_over_clip` (pinch, lift over the walls, carry onto the slot, servo, lower, let go),
   then `press_home` (close the fingers, press the cable home, tap its neighbours, withdraw).
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
from maniladder_ms.solvers.rope.clip_phases import RELEASE_ABOVE_TOP, lay_over_clip, press_home

FIRST_CAPSULE = 2  # the capsule pressed into the first clip, counted from the cable's end beside that clip
CAPSULE_STEP = 7  # capsules between those pressed into consecutive clips: 14 cm of cable for the clips' 10 cm
# spacing (with 12 cm, seeds 100-102, the cable dragged along by one clip's carry ended within 5 cm of the next
# clip's axis, where the spread fingertips landed on that clip's wall)
MIN_STEP = 6  # never fewer capsules between consecutive clips' capsules: 12 cm of cable for 10 cm
PICK_SHIFTS = (0, 1, -1, 2)  # capsules tried after the nominal one, in this order
TIP_REACH = 0.06  # the spread fingertips reach this far sideways of the pinched capsule's centre (seeds 100-103: the
# middle tip landed on a clip wall with the capsule 5.0-6.6 cm from that clip's axis, never at 8.6 cm or more)
TIP_HALF_WIDTH = 0.015  # and this far along the cable
TIP_CLEARANCE = 0.005  # kept from a clip's outline
TIP_SAMPLES = 7  # points sampled across the fingertips' span
REPRESS_ROUNDS = 2  # passes over the clips pressing again those not full


def pinch_is_clear(task, k: int) -> bool:
    """Whether the spread fingertips pinching capsule `k` land clear of every clip: sample points across the
    tips' span (`TIP_REACH` each side of the capsule, `TIP_HALF_WIDTH` along it), none within `TIP_CLEARANCE` of
    a clip's outline (its walls' outer faces and its ends), seen from above."""
    link = task.rope.links[k]
    p, yaw = link.pose.p[:, :2], rope.segment_yaw(link.pose.q)
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


def pick_capsule(task, nominal: int, previous: int | None, direction: int) -> int:
    """The capsule to pinch for the next clip: `nominal` or, if its pinch is not clear, the first of its
    neighbours (`PICK_SHIFTS`, along `direction`: +1 counting up from capsule 0, -1 down) that is, keeping at
    least `MIN_STEP` capsules after `previous`; `nominal` if none is."""
    last = task.rope_config.segments - 2  # the clip's 3 capsules must exist: the pick's neighbours too
    for shift in PICK_SHIFTS:
        k = nominal + direction * shift
        if not 1 <= k <= last:
            continue
        if previous is not None and direction * (k - previous) < MIN_STEP:
            continue
        if pinch_is_clear(task, k):
            return k
    return nominal


def first_end_direction(task) -> int:
    """+1 when the cable's capsule 0 lies nearer the first clip than its last capsule (count up), else -1."""
    centres = task.rope.points()[:, 1:-1]
    first_clip = task.clips[0].pose.p
    near0 = torch.linalg.norm(centres[:, 0, :2] - first_clip[:, :2], dim=1)
    near1 = torch.linalg.norm(centres[:, -1, :2] - first_clip[:, :2], dim=1)
    return 1 if bool((near0 <= near1)[0]) else -1


def press_again(s: DrivenSolver, task):
    """Press again each clip holding fewer than `min_segments` capsules (first to last, `REPRESS_ROUNDS` passes):
    `press_home` from the TCP pose that would have let a pinched capsule go over its slot."""
    for _ in range(REPRESS_ROUNDS):
        counts = task.inside_counts()[0]
        short = [clip for clip, n in zip(task.clips, counts.tolist()) if n < task.min_segments]
        if not short:
            return
        for clip in short:
            slot = clip.pose.p.clone()
            slot[:, 2] = clip.top + RELEASE_ABOVE_TOP + task.rope_config.radius
            along = DrivenSolver.neutral_yaw(clip.axis(), torch.pi)
            low, q = DrivenSolver.scissor_pose(slot, along, around=along)
            press_home(s, task, clip, low, q)


@register_solver("RouteCableClipsHand", control_modes=TCP_DELTA_MODES)
def solve_route_cable_clips_hand(env, seed: int) -> dict:
    """For each clip in order `pick_capsule`, `lay_over_clip`, `press_home`; then hold still until success."""
    with DrivenSolver.episode(env, seed) as s:
        task = env.unwrapped
        direction = first_end_direction(task)
        start = FIRST_CAPSULE if direction > 0 else task.rope_config.segments - 1 - FIRST_CAPSULE
        previous = None
        for clip in task.clips:
            nominal = start if previous is None else previous + direction * CAPSULE_STEP
            k = pick_capsule(task, nominal, previous, direction)
            low, q = lay_over_clip(s, task, clip, k)
            press_home(s, task, clip, low, q)
            previous = k
        press_again(s, task)
        s.hold_until_success()
        return s.info
