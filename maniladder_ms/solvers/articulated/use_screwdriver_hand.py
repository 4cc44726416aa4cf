"""Scripted solver of UseScrewdriverHand (tasks/articulated/use_screwdriver_hand.py): the LEAP hand takes the
screwdriver out of its stand in a top-down power grasp, sets its blade into the screw's cross slot and turns the
screw counter-clockwise by turning the wrist.

The screwdriver does not hang straight in the grasp: out of the stand it tilts about the fingers' contacts (the
flat handle 6-16 degrees after the alignment, seeds 100 101 102 105 114 123), so every phase after the lift is closed on the tool's
measured tip and blade, never on where the hand is: the hand stays top-down, and its targets are chosen so that the
measured tip goes where it should (its offset in the TCP frame read afresh every control step).

1. `pick`: above the handle, the hand yawed to it (its finger row along the flat handle's width) and aimed so the
   handle's axis lies `SEAT_Y` towards the middle finger, preshape, down onto it, close the power grasp, lift
   slowly out of the stand.
2. `carry`: the tip to a point `HOVER` above the screw's head.
3. `align`: turn the hand about the vertical through the tip until the blade lies along one of the slot's arms
   (of the four, the one reached by the largest clockwise turn, at most three quarters, that keeps Panda joint 7
   below its upper stop: the counter-clockwise turn of the screw then has the most of joint 7's range).
4. `insert`: the tip down into the slot, `INSERT_DEPTH` below the head's top.
5. `turn`: the hand turns counter-clockwise about the vertical through the tip, the tip held in the slot, until the
   task reports success (or joint 7 nears its limit, or the blade slips out of the slot: then 2-5 again, the
   alignment's clockwise turn winding the wrist back).
6. Hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply, quaternion_invert

from maniladder_ms.geometry import matrix_yaw, wrap_angle
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import J7_LIMIT, J7_MARGIN, LEAD, tcp_yaw, wrist_angle
from maniladder_ms.tasks.articulated.use_screwdriver_hand import HANDLE_LENGTH, UseScrewdriverHandEnv

ARM, HAND = "arm", "hand"
HANDLE_PERIOD = np.pi  # the flat handle looks the same turned half a turn: the grasp yaw nearest the rest pose's
# m along the TCP's y the handle's axis is put at the grasp: under the middle finger (the finger row's knuckles lie
# at -3.1 (index), +1.5 (middle) and +6.0 cm (ring) along it), so the 8 cm handle spans the row
SEAT_Y = 0.0145
APPROACH = 0.1  # m above the handle's top where the hand takes its preshape
GRASP_DEPTH = 0.06  # m: the TCP aimed this far below the handle's top as the hand closes (the palm stops on the top)
LIFT = 0.14  # m the hand rises after the grasp (the tip, 7 cm below the handle, clears the 7.5 cm stand)
LIFT_STEPS = 40  # control steps of the lift (a slow lift: the tool swings less as it leaves the stand)
HOVER = 0.03  # m above the head's top where the tip goes before it is aligned and lowered
INSERT_DEPTH = 0.005  # m below the head's top the tip is pressed to (the slot is 8 mm deep, the rule asks 3 mm)
TIP_TOL = 0.0015  # m: the tip is where it should be within this (the blade has 1.5 mm of play across the slot)
ALIGN_TOL = np.deg2rad(3)  # the blade lies along the slot within this
MOVE_STEPS = 100  # control steps a closed-loop move may take
# a closed-loop move also ends once the tip has come no closer than this in `STALL_STEPS` steps. With the flat
# handle the tip stalled 2-3 mm short of the hover and insertion goals (`TIP_TOL`) for the whole `MOVE_STEPS` on
# seeds 103 and 108 of 100-149; the remaining error lies within the slot's depth and the turn's closed loop
STALL_GAIN = 0.0005
STALL_STEPS = 10
ALIGN_STEPS = 200  # control steps the alignment may take (up to three quarters of a turn)
SETTLE_STEPS = 10  # control steps the hand keeps still after the carry (the tool's swing dies down)
SLOT_PERIOD = np.pi / 2  # the cross slot repeats every quarter turn
# rad the yaw target leads the hand's in the turn: at the twist module's `LEAD` (0.3) the tip walked out along a slot
# arm into the gap round the head on seed 103 (8/10 on seeds 100-109); at 0.15 9/10, no slower in control steps
TURN_LEAD = 0.15
TURN_STEPS = 200  # control steps one turn may take (pi at ~0.035 rad a step: ~90)
# the turn stops once the tip has risen this far out of the slot (the blade slipped out: seed 108 at ~105 degrees);
# the solver then takes the tip back up, aligns and inserts it again, at most `ENGAGES` times in all
SLIPPED = 0.002
ENGAGES = 3


def blade_yaw(task: UseScrewdriverHandEnv) -> torch.Tensor:
    """(n,) world yaw of the blade's width (the screwdriver's x axis, projected on the table)."""
    return matrix_yaw(task.screwdriver.pose.to_transformation_matrix()[:, :3, :3])


def tip_in_tcp(s: DrivenSolver, task) -> torch.Tensor:
    """(n, 3) the screwdriver's tip in the TCP frame, as it is now."""
    tcp = s.tcp(ARM)
    return quaternion_apply(quaternion_invert(tcp.q), task.tip() - tcp.p)


def tip_target(s: DrivenSolver, task, goal: torch.Tensor, yaw: torch.Tensor):
    """(p, q): the top-down TCP pose at `yaw` that puts the measured tip at `goal` (n, 3)."""
    q = top_down_quat(yaw, goal.shape[0], goal.device)
    return goal - quaternion_apply(q, tip_in_tcp(s, task)), q


def move_tip(s: DrivenSolver, task, goal, yaw=None, max_steps: int = MOVE_STEPS, tol: float = TIP_TOL):
    """Closed loop on the measured tip: step until it is within `tol` of `goal()` (n, 3), or it has come no closer
    by `STALL_GAIN` in `STALL_STEPS` steps, or `max_steps`; the hand top-down at `yaw()` (None: its yaw at the
    move's start, held: read afresh each step, the yaw crept while the tip stalled and wound joint 7 ~0.9 rad in
    100 steps into its stop, seed 103 of 100-149)."""
    held_yaw = tcp_yaw(s, ARM).clone()
    best, since = float("inf"), 0
    for _ in range(max_steps):
        g = goal()
        d = float(torch.linalg.norm(task.tip() - g, dim=1).max())
        if d < tol:
            return
        if d < best - STALL_GAIN:
            best, since = d, 0
        else:
            since += 1
            if since >= STALL_STEPS:
                return
        s.step({ARM: tip_target(s, task, g, held_yaw if yaw is None else yaw())})


def pick(s: DrivenSolver, task):
    top = task.screwdriver.pose.p + torch.tensor([0.0, 0.0, HANDLE_LENGTH], device=task.device)
    handle_yaw = matrix_yaw(task.screwdriver.pose.to_transformation_matrix()[:, :3, :3])
    q = top_down_quat(s.neutral_yaw(handle_yaw, HANDLE_PERIOD), top.shape[0], top.device)
    top = top - quaternion_apply(q, torch.tensor([[0.0, SEAT_Y, 0.0]], device=task.device).expand_as(top))
    s.release(HAND, steps=1)
    s.move({ARM: (s.above(top, APPROACH), q)}, max_steps=80)
    s.set_ee(HAND, "preshape", steps=5)
    s.move({ARM: (s.above(top, -GRASP_DEPTH), q)}, max_steps=50, pos_tol=0.003)
    s.close_hand(HAND, "power")
    start = s.tcp(ARM).p.clone()
    for k in range(1, LIFT_STEPS + 1):
        s.step({ARM: (s.above(start, LIFT * k / LIFT_STEPS), q)})


def align(s: DrivenSolver, task):
    """Turn the blade into line with a slot arm, the tip kept `HOVER` above: of the arms reached turning clockwise
    by -1/4 to 3/4 of a turn, the one with the largest turn that keeps joint 7 `J7_MARGIN` below its upper stop
    (where none does, the one half a turn to a quarter counter-clockwise)
    (a clockwise turn of the hand raises joint 7, and the screw's counter-clockwise turn then has the most of its
    range: the hand's grasp yaw follows the handle's, +-45 degrees)."""
    slot = matrix_yaw(task.screw.pose.to_transformation_matrix()[:, :3, :3])
    clockwise = torch.remainder(blade_yaw(task) - slot, SLOT_PERIOD)
    wrist = wrist_angle(s, ARM)
    best = clockwise - 2 * SLOT_PERIOD
    for k in (-1, 0, 1):
        turn_k = clockwise + k * SLOT_PERIOD
        best = torch.where(wrist + turn_k <= J7_LIMIT - J7_MARGIN, turn_k, best)
    hover = lambda: s.above(task.head_top(), HOVER)  # noqa: E731
    last, turned = blade_yaw(task), torch.zeros_like(clockwise)  # the blade's turn so far, unwrapped
    for _ in range(ALIGN_STEPS):
        now = blade_yaw(task)
        turned = turned + wrap_angle(now - last)
        last = now
        err = -best - turned
        if bool((err.abs() < ALIGN_TOL).all()):
            return
        s.step({ARM: tip_target(s, task, hover(), tcp_yaw(s, ARM) + err.clamp(-LEAD, LEAD))})


def turn(s: DrivenSolver, task):
    """Counter-clockwise about the vertical through the tip, held `INSERT_DEPTH` deep on the screw's axis, until
    success, joint 7 nears its limit or the blade slips out of the slot."""
    deep = lambda: s.above(task.head_top(), -INSERT_DEPTH)  # noqa: E731
    for _ in range(TURN_STEPS):
        out = task.tip()[:, 2] > task.head_top()[:, 2] - SLIPPED
        if bool(s.info["success"].all()) or bool((wrist_angle(s, ARM) <= -J7_LIMIT + J7_MARGIN).all()) \
                or bool(out.all()):
            return
        s.step({ARM: tip_target(s, task, deep(), tcp_yaw(s, ARM) + TURN_LEAD)})


def engage_and_turn(s: DrivenSolver, task):
    """Tip over the head, blade along a slot arm, tip into the slot, turn."""
    move_tip(s, task, lambda: s.above(task.head_top(), HOVER), tol=0.005)
    for _ in range(SETTLE_STEPS):
        s.hold_still()
    align(s, task)
    move_tip(s, task, lambda: s.above(task.head_top(), HOVER))
    move_tip(s, task, lambda: s.above(task.head_top(), -INSERT_DEPTH))
    turn(s, task)


@register_solver("UseScrewdriverHand", control_modes=TCP_DELTA_MODES)
def solve_use_screwdriver_hand(env, seed: int) -> dict:
    """Pick the screwdriver, carry its tip over the screw, align the blade, insert it, turn."""
    with DrivenSolver.episode(env, seed) as s:
        task: UseScrewdriverHandEnv = env.unwrapped
        pick(s, task)
        for _ in range(ENGAGES):
            engage_and_turn(s, task)
            if bool(s.info["success"].all()) or not bool(s.info["screwdriver_held"].all()):
                break
        s.hold_until_success()
        return s.info
