"""Scripted solver of WrapRopeAroundBoxHands (tasks/rope/wrap_rope_around_box_hands.py): the rope is passed hand
over hand round the box, counter-clockwise seen from above (the way it already leaves its tie): the right hand
carries the free end round the box's right and far faces and lays it down beyond the far-left corner; the left
hand takes it there and carries it on round the near face, over the tied-down part, to the near-right corner and
lays it down; both hands let go. Each carry keeps the pinch `PATH_OFFSET` off the box's faces (a rounded
rectangle about it, at `CARRY_Z`) and turns the hand with the path, fingers along it: part of a turn each (one
hand could not turn its wrist the whole way).

1. Both hands open the scissor fingers; the right hand pinches the rope's last capsule from the side with room
   for its index finger (where that capsule lies within `END_ROOM` of the rest of the rope, the roomiest of the
   last `END_CHOICE` first; where it lies `END_ROOM` to `NARROW_ROOM` from it, the fingers spread only
   `NARROW_SPREAD`; where a finger lands on the rope beside it, it tries the last capsule, or capsule
   `RETRY_FROM_END`).
2. It lifts the pinch to `CARRY_Z` and glides to the path at bearing `RIGHT_START` (box frame), turning its
   wrist at most `YAW_STEP` a control step; the left hand goes to wait (`WAIT_OUT`, `WAIT_Z`).
3. The right hand carries the pinch along the path to bearing `RIGHT_END`, `ARC_STEP` a control step.
4. It lays the end down `HANDOVER_OFFSET` off the box pointing away from it, opens, rises `RETREAT_HEIGHT` and
   moves back `RETREAT_BACK`.
5. The left hand pinches the same capsule where it lies, from `APPROACH_HEIGHT` above it.
6. It lifts the pinch to `CARRY_Z`, glides onto the path and carries it on to bearing `LEFT_END`.
7. It lays the rope down there, opens and rises `RETREAT_HEIGHT`.
8. Hold still until success.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.deformables import rope
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.tasks.rope.wrap_rope_around_box_hands import BOX_HALF, WrapRopeAroundBoxHandsEnv

PATH_OFFSET = 0.05  # the carried pinch stays this far off the box's faces: the pinching fingers reach ~4 cm either side
HANDOVER_OFFSET = 0.09  # the right hand lays the free end down this far off the box, pointing away from it, so
# the left hand's fingers, along it, close clear of the box's faces
CARRY_Z = 0.035  # the pinched capsule's centre while carried: the fingertips 3 cm up, over the tied-down rope (1.6 cm)
LAY_Z_CLEARANCE = 0.004  # the rope is laid down with its pinched capsule this far above its resting height
ARC_STEP = 0.006  # metres of path a control step while the rope is held (faster swings it out of the pinch)
RIGHT_START = -np.pi / 2  # bearings (box frame, rad, counter-clockwise from the box's +x) of the right hand's carry
RIGHT_END = 2 * np.pi / 3
LEFT_END = 5 * np.pi / 4  # the left hand carries on from RIGHT_END to here: past the tie (at pi) by pi / 4
RIGHT_YAW_SHIFT = 0.0  # hand yaw minus the path's tangent yaw for each hand (either way round pinches the rope)
LEFT_YAW_SHIFT = -np.pi
YAW_STEP = 0.05  # rad a control step the pinching hand turns while gliding (a fast wrist turn drops the rope)
DESCENT_STEPS = 25  # at most this many control steps for a pinch's last descent (it stops ~5 mm short on the rope)
RETRY_FROM_END = 2  # a right-hand pinch that does not hold its capsule opens and tries this one (from the free end)
RETRY_HEIGHT = 0.04  # a pinch that missed rises this far before the next try
# where the free end lies 3-6 cm from the rope's tied leg a spread fingertip comes down on that leg (seeds 103, 109,
# 121: index or middle tip on capsules 5-11, nothing held, on both tries). The right hand's end pinch comes down on
# the side whose index finger has the most room (the distance from a point `INDEX_REACH` off the capsule on that
# side to the nearest capsule more than `NEAR_LINKS` along the rope from it: seed 103 then held the last capsule);
# where the last capsule itself lies within `END_ROOM` of that rope, it first tries the one of the last
# `END_CHOICE` with the most room (seed 137 then held; always the roomiest, seeds 102, 103 and 106 then failed at
# the handover: the end trails the pinch)
END_CHOICE = 3
END_ROOM = 0.05
INDEX_REACH = 0.04
NEAR_LINKS = 5
# "scissor_open" spreads the two fingers 0.25 rad at their side joints: their tips' middles ~3.7 cm either side of
# the rope, their outer faces ~4.7 cm (seed 109: the fingertip link frames at step 62), and where the capsule lies
# within ~6 cm of the rest of the rope the outer finger comes down on that (109, 112, 114, 128: 5.3-6.1 cm; the
# middle tip on capsule 7 of 109, the TCP stopped 9 mm high, and the closing fingers shot the end capsule 50 cm out
# from under them). Where the last capsule lies `END_ROOM` to `NARROW_ROOM` from the rope `NEAR_LINKS` or more
# away, the end pinch comes down spread `NARROW_SPREAD` instead (the tips' middles ~2.7 cm out, ~9 mm clear of the
# rope): 109, 114 and 128 then held the end and succeeded, 103 still did. Not under `END_ROOM`, where the roomiest of
# the last `END_CHOICE` is pinched: narrow there, 121 held, but 130 and 137 (successes spread wide) then failed at
# the handover (left hand missed). Both constants chosen by looking at seeds 100-149's failures
NARROW_ROOM = 0.062
NARROW_SPREAD = 0.10
SETTLE_STEPS = 3  # control steps held after each glide of the held rope
OPEN_STEPS = 6  # control steps to open a hand's scissor fingers
WAIT_OUT, WAIT_Z = 0.1, 0.2  # the left hand waits this much further out than the handover point, this high
RETREAT_HEIGHT = 0.12  # a hand that let go rises this far
RETREAT_BACK = 0.25  # and the right hand moves this far back towards its own side (-y), out of the left hand's way


def box_distance(points_xy: torch.Tensor, centre: torch.Tensor, yaw: torch.Tensor) -> torch.Tensor:
    """Top-down distance [B, N] of points [B, N, 2] from the footprint of a box (`BOX_HALF`) centred at `centre`
    [B, 2], turned by `yaw` [B] (0 inside it)."""
    rel = points_xy - centre[:, None]
    c, s = torch.cos(yaw)[:, None], torch.sin(yaw)[:, None]
    local = torch.stack([c * rel[..., 0] + s * rel[..., 1], -s * rel[..., 0] + c * rel[..., 1]], dim=-1)
    half = torch.tensor(BOX_HALF[:2], device=points_xy.device)
    return torch.linalg.norm((local.abs() - half).clamp(min=0), dim=-1)


def path_point(task: WrapRopeAroundBoxHandsEnv, bearing: torch.Tensor, offset: float = PATH_OFFSET) -> torch.Tensor:
    """The point [B, 2] `offset` off the box's footprint on the ray from its centre at `bearing` [B] (box frame)."""
    centre, yaw = task.box_frame()
    world = yaw + bearing
    ray = torch.stack([torch.cos(world), torch.sin(world)], dim=1)
    low, high = torch.zeros_like(bearing), torch.full_like(bearing, 0.5)
    for _ in range(30):  # bisection: box_distance grows along the ray
        mid = (low + high) / 2
        out = box_distance((centre + mid[:, None] * ray)[:, None], centre, yaw)[:, 0] > offset
        high, low = torch.where(out, mid, high), torch.where(out, low, mid)
    return centre + high[:, None] * ray


def path_pinch(task: WrapRopeAroundBoxHandsEnv, bearing: torch.Tensor, z: float, yaw_shift: float,
               offset: float = PATH_OFFSET) -> tuple[torch.Tensor, torch.Tensor]:
    """Where the pinched capsule goes on the path at `bearing` [B]: its centre [B, 3] `z` up, and the hand's yaw
    [B], its fingers along the path's tangent (counter-clockwise) turned by `yaw_shift`."""
    eps = 1e-3
    tangent = path_point(task, bearing + eps, offset) - path_point(task, bearing - eps, offset)
    yaw = torch.atan2(tangent[:, 1], tangent[:, 0]) + yaw_shift
    p = path_point(task, bearing, offset)
    return torch.cat([p, torch.full_like(p[:, :1], z)], dim=1), yaw


def pinch_pose(centre: torch.Tensor, yaw: torch.Tensor, side: str):
    """TCP pose (p, q) of `side`'s hand pinching a capsule at `centre` with its fingers along `yaw`."""
    return DrivenSolver.scissor_pose(centre, yaw, mirror=side == "left", around=yaw)


def nearest_turn(yaw: torch.Tensor, reference: torch.Tensor, period: float) -> torch.Tensor:
    """`yaw` shifted by whole `period`s to lie within half a period of `reference`."""
    return reference + torch.remainder(yaw - reference + period / 2, period) - period / 2


def glide_pinch(s: DrivenSolver, side: str, start: tuple, end: tuple):
    """Move a pinching hand from (centre, yaw) `start` to `end` in a straight line, turning its wrist with it (the
    way round that is shorter), `ARC_STEP` / `YAW_STEP` a control step, whichever takes longer."""
    (c0, y0), (c1, y1) = start, end
    y1 = nearest_turn(y1, y0, 2 * np.pi)
    steps = max(1, int(np.ceil(max(float((c1 - c0).norm(dim=1).max()) / ARC_STEP,
                                   float((y1 - y0).abs().max()) / YAW_STEP))))
    arm = f"{side}_arm"
    for k in range(1, steps + 1):
        s.step({arm: pinch_pose(c0 + (c1 - c0) * k / steps, y0 + (y1 - y0) * k / steps, side)})
    s.move({arm: pinch_pose(c1, y1, side)}, max_steps=SETTLE_STEPS, pos_tol=0.003)
    return c1, y1


def carry(s: DrivenSolver, task: WrapRopeAroundBoxHandsEnv, side: str, start: float, end: float, yaw_shift: float):
    """Carry the pinched rope along the path from bearing `start` to `end`, `ARC_STEP` of path a control step."""
    b, device = task.num_envs, task.device
    steps = int(np.ceil(abs(end - start) * 0.12 / ARC_STEP))  # ~12 cm of path a radian
    arm = f"{side}_arm"
    for k in range(1, steps + 1):
        bearing = torch.full((b,), start + (end - start) * k / steps, device=device)
        s.step({arm: pinch_pose(*path_pinch(task, bearing, CARRY_Z, yaw_shift), side)})
    at = path_pinch(task, torch.full((b,), end, device=device), CARRY_Z, yaw_shift)
    s.move({arm: pinch_pose(*at, side)}, max_steps=SETTLE_STEPS, pos_tol=0.003)
    return at


def far_rope(task: WrapRopeAroundBoxHandsEnv, link) -> torch.Tensor:
    """Top-down centres [B, N, 2] of the capsules more than `NEAR_LINKS` along the rope from capsule `link`."""
    k = task.rope.links.index(link)
    return torch.stack([l.pose.p[:, :2] for i, l in enumerate(task.rope.links) if abs(i - k) > NEAR_LINKS], dim=1)


def room(task: WrapRopeAroundBoxHandsEnv, link, xy: torch.Tensor) -> torch.Tensor:
    """Distance [B] from points `xy` [B, 2] to the nearest capsule more than `NEAR_LINKS` along from `link`."""
    return (far_rope(task, link) - xy[:, None]).norm(dim=-1).amin(dim=1)


def end_pinch_links(task: WrapRopeAroundBoxHandsEnv) -> list:
    """The capsules the right hand's end pinch tries: the last one, then `RETRY_FROM_END`; where the last lies within
    `END_ROOM` of the rest of the rope, first the one of the last `END_CHOICE` with the most room (one env: the
    solver drives num_envs 1), then the last one."""
    n = task.rope_config.segments
    ends = [task.rope.links[n - 1 - k] for k in range(END_CHOICE)]
    first = ends[0]
    if float(room(task, first, first.pose.p[:, :2]).min()) < END_ROOM:
        first = max(ends, key=lambda link: float(room(task, link, link.pose.p[:, :2]).min()))
    return [first, task.rope.links[n - 1 - RETRY_FROM_END] if first is ends[0] else ends[0]]


def roomy_yaw(task: WrapRopeAroundBoxHandsEnv, side: str, link, centre: torch.Tensor, yaw: torch.Tensor):
    """Of `yaw` and `yaw` + pi (a scissor pinch of capsule `link` at `centre`), the one whose index finger's side
    has the most room off the rest of the rope (`INDEX_REACH`, `NEAR_LINKS`)."""
    rooms = []
    for y in (yaw, yaw + np.pi):
        tcp, _ = pinch_pose(centre, y, side)
        along = torch.stack([torch.cos(y), torch.sin(y)], dim=1)
        off = tcp[:, :2] - centre[:, :2]
        across = torch.nn.functional.normalize(off - (off * along).sum(1, keepdim=True) * along, dim=1)
        rooms.append(room(task, link, centre[:, :2] + INDEX_REACH * across))
    return torch.where(rooms[1] > rooms[0], yaw + np.pi, yaw)


def open_posture(task: WrapRopeAroundBoxHandsEnv, link, narrow: bool):
    """The scissor's approach posture over capsule `link`: "scissor_open", or where `narrow`, `link` is the rope's
    last capsule and it lies within `NARROW_ROOM` of the rest of the rope, its two fingers spread only
    `NARROW_SPREAD` (one env)."""
    posture = LEAP_SYNERGIES["scissor_open"].copy()
    last = link is task.rope.links[task.rope_config.segments - 1]
    if narrow and last and float(room(task, link, link.pose.p[:, :2]).min()) < NARROW_ROOM:
        index_side, middle_side = 0, 4  # the index and middle fingers' side joints (LEAP order)
        posture[index_side], posture[middle_side] = -NARROW_SPREAD, NARROW_SPREAD
    return posture


def pinch(s: DrivenSolver, task: WrapRopeAroundBoxHandsEnv, side: str, links: list, yaw_near: torch.Tensor,
          roomy: bool = False):
    """Come down over the first of capsules `links` where it lies and close the scissor pinch on it, fingers along
    it (of the two yaws, the one nearest `yaw_near`; `roomy`: the one with room for the index finger,
    `roomy_yaw`, and the fingers spread less where the rope lies near, `open_posture`); where that does not hold it
    (a finger landed on the rope beside it), open, rise `RETRY_HEIGHT` and try the next. Returns the pinch
    (centre, yaw) and the capsule."""
    arm, hand = f"{side}_arm", f"{side}_hand"

    def target(link):
        centre = link.pose.p.clone()
        centre[:, 2] = task.rope_config.radius
        yaw = nearest_turn(rope.segment_yaw(link.pose.q), yaw_near, np.pi)
        return centre, roomy_yaw(task, side, link, centre, yaw) if roomy else yaw

    p, q = pinch_pose(*target(links[0]), side)
    posture = open_posture(task, links[0], roomy)  # the first capsule's room decides it for every try
    s.set_ee(hand, posture, steps=0)
    s.move({arm: (s.above(p, APPROACH_HEIGHT), q)}, max_steps=60, pos_tol=0.01)
    for link in links:
        centre, yaw = target(link)  # where the capsule lies now
        p, q = pinch_pose(centre, yaw, side)
        s.move({arm: (p, q)}, max_steps=DESCENT_STEPS, pos_tol=0.003)
        s.close_hand(hand, "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        if bool(task.ee.holds(link, side).all()):
            break
        s.set_ee(hand, posture, steps=OPEN_STEPS)
        s.move({arm: (s.above(p, RETRY_HEIGHT), q)}, max_steps=15, pos_tol=0.01)
    return (centre, yaw), link


def lift(s: DrivenSolver, side: str, at: tuple, z: float):
    """Raise the pinched capsule straight up to `z`."""
    centre, yaw = at
    up = centre.clone()
    up[:, 2] = z
    return glide_pinch(s, side, at, (up, yaw))


def lay_down(s: DrivenSolver, task: WrapRopeAroundBoxHandsEnv, side: str, at: tuple, bearing: float,
             yaw_shift: float, offset: float = PATH_OFFSET, outwards: bool = False):
    """Move the pinch from `at` to `offset` off the box at `bearing` (`outwards`: the fingers turned to point the
    rope's end away from the box), lower the pinched capsule to the table and open the scissor fingers; returns
    the hand's last TCP pose."""
    b = task.num_envs
    bearing = torch.full((b,), bearing, device=task.device)
    out = path_pinch(task, bearing, CARRY_Z, yaw_shift, offset)
    if outwards:
        _, box_yaw = task.box_frame()
        out = (out[0], nearest_turn(box_yaw + bearing, at[1], np.pi))
    out = glide_pinch(s, side, at, out)
    low = out[0].clone()
    low[:, 2] = task.rope_config.radius + LAY_Z_CLEARANCE
    low = glide_pinch(s, side, out, (low, out[1]))
    s.set_ee(f"{side}_hand", "scissor_open", steps=OPEN_STEPS)
    return pinch_pose(*low, side)


@register_solver("WrapRopeAroundBoxHands", control_modes=TCP_DELTA_MODES)
def solve_wrap_rope_around_box_hands(env, seed: int) -> dict:
    """Right hand: pinch near the free end, carry it round the right and far faces, lay it down; left hand:
    pinch it there, carry it on round the near face over the tie and past the right face, lay it down; both
    let go (see the module docstring)."""
    with DrivenSolver.episode(env, seed) as s:
        task: WrapRopeAroundBoxHandsEnv = env.unwrapped
        device, b = task.device, task.num_envs
        links = end_pinch_links(task)
        s.set_ee("right_hand", "scissor_open", steps=0)
        s.set_ee("left_hand", "scissor_open", steps=0)
        start = path_pinch(task, torch.full((b,), RIGHT_START, device=device), CARRY_Z, RIGHT_YAW_SHIFT)
        at, link = pinch(s, task, "right", links, start[1], roomy=True)
        at = lift(s, "right", at, CARRY_Z)
        glide_pinch(s, "right", at, start)
        handover = path_point(task, torch.full((b,), RIGHT_END, device=device), HANDOVER_OFFSET + WAIT_OUT)
        wait = torch.cat([handover, torch.full_like(handover[:, :1], WAIT_Z)], dim=1)
        _, box_yaw = task.box_frame()
        s.arm_targets["left_arm"] = pinch_pose(wait, box_yaw + RIGHT_END, "left")  # the left hand waits beyond it
        at = carry(s, task, "right", RIGHT_START, RIGHT_END, RIGHT_YAW_SHIFT)
        p, q = lay_down(s, task, "right", at, RIGHT_END, RIGHT_YAW_SHIFT, HANDOVER_OFFSET, outwards=True)
        s.move({"right_arm": (s.above(p, RETREAT_HEIGHT), q)}, max_steps=20, pos_tol=0.02)
        away = s.above(p, RETREAT_HEIGHT)
        away[:, 1] -= RETREAT_BACK
        s.arm_targets["right_arm"] = (away, q)
        start = path_pinch(task, torch.full((b,), RIGHT_END, device=device), CARRY_Z, LEFT_YAW_SHIFT)
        at, _ = pinch(s, task, "left", [link], start[1])
        at = lift(s, "left", at, CARRY_Z)
        glide_pinch(s, "left", at, start)
        at = carry(s, task, "left", RIGHT_END, LEFT_END, LEFT_YAW_SHIFT)
        p, q = lay_down(s, task, "left", at, LEFT_END, LEFT_YAW_SHIFT)
        s.move({"left_arm": (s.above(p, RETREAT_HEIGHT), q)}, max_steps=20, pos_tol=0.02)
        s.hold_until_success()
        return s.info
