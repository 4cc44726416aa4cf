"""Scripted solver of NestCupsHands (tasks/rigid/nest_cups_hands.py): the left hand puts the middle cup into the
large one, then the right hand the small cup into the middle one.

1. Both hands come down onto their cups at once (left: the middle, right: the small), top-down, open in
   "preshape", their TCPs GRASP_BELOW_RIM under the rims and GRASP_OFFSET from the axes (`come_down`).
2. The left closes "power" round the middle cup, lifts it CARRY_BOTTOM clear of the table and takes its tilt in
   the grip out (`pick`); it carries it over the large cup, straightens it again, aims it closed loop, lowers it
   closed loop until its bottom is RELEASE_BOTTOM over the large cup's floor and opens (`drop_into`): the cup
   falls the rest of the way along the large cup's tapered wall; the left rises and moves LEFT_ASIDE.
3. The right, waiting open round the small cup, does the same with it into the middle cup, keeping it upright
   closed loop as it lowers it (`drop_into(upright=True)`: the small cup turns in the grip as it is carried).
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.agents.effectors import TOUCH_FORCE, contact_forces
from maniladder_ms.geometry import tilt, uprighting
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import HandoverSolver, close_hands, glide
from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.tasks.rigid.nest_cups_hands import CUP_HEIGHT, NestCupsHandsEnv

# the top-down grasp: the hand's yaw (TCP x along the fingers: +x, away from the robot, the thumb towards it), the
# TCP this far under the cup's rim, and this far from its axis in the TCP frame (x towards the fingertips, y along
# the finger row; the left hand's row mirrored): PlaceMugOnCoasterHand's mug grasp. On seed 103 the offset's row
# component not mirrored for the left pushed the middle cup 4 cm at the close; at 3.5 cm under the rim the small cup
# slipped out in the lift
YAW = {"left": 0.0, "right": 0.0}
GRASP_BELOW_RIM = 0.04
GRASP_OFFSET = (-0.015, -0.015, 0.0)
APPROACH_ABOVE = 0.1  # the hands come down onto their grasps from this far above
PRESHAPE_STEPS = 5
CLOSE_STEPS = 40  # the hands close over this many control steps
# the left's grip on the middle cup: "power" with the thumb's two outer bends (LEAP joints 14, 15) at THUMB_BENDS
# (the right keeps "power": with 0.3 for both hands seeds 100-111 gave 8/12). With
# "power"'s 0.8 the left thumb tip's lowest corner hangs 1-4 mm under the middle cup's bottom and 6 cm out from its
# axis (seeds 0, 1, 3, 4): it lands on the large cup's rim with the cup's bottom still at the mouth (the first touch
# with the bottom 0.1-0.2 cm under the rim, seeds 0-5) and shoves the cup 8-10 mm off axis; at 0.3 it is 14-15 mm
# over the bottom (same seeds), the cup within 1 deg of upright in the grip. At 0.5 the cup slid 1.5-4 cm down
# in the grip in the lift (seeds 0, 1, 3, 4, 7)
THUMB_OUTER_BENDS = [14, 15]
THUMB_BENDS = 0.3
CARRY_BOTTOM = 0.12  # m: the carried cup's bottom this high over the table (over the 9 cm rims)
LIFT_MARGIN = 0.01  # m: the lift goes this much higher, the carry and the lowering start there
CARRY_STEP = 0.01  # m a control step along the lift and the carry
# the held cup's bottom this far over the container's floor when the hand lets go: its lowest fingertip ~1 cm over
# the container's rim (seed 100). At 7 cm the dropped middle cup wedged 6 mm high in the large one (seeds 100, 106)
RELEASE_BOTTOM = 0.055
LOWER_STEP = 0.004  # m a control step of the closed-loop lowering
STRAIGHTEN_STEPS = 30  # control steps at most for the wrist to take the held cup's tilt out
# the upright lowering (the small cup only): the held cup tilted more than HOLD_TILT in the grip, the descent waits,
# at most HOLD_STEPS in all. Without it the small cup reached the middle one's mouth tilted 7-11 deg (seeds 110, 132)
# or 25-31 deg (103, 123) and its bottom caught the wall, tipping the nest
HOLD_TILT = np.deg2rad(3.0)  # rad
HOLD_STEPS = 15
AIMS = 2  # closed-loop moves putting the held cup's axis over the container's, before the lowering
# the release: the squeeze relaxed (targets to the joints' positions), the thumb opens over RELEASE_STEPS, then the
# fingers over FINGER_OPEN_STEPS. Opening everything at once over 10 steps, or the fingers first, the opening
# fingers swung the small cup out of the middle one's mouth and it stayed lying on them (seeds 100, 106, 108)
RELEASE_STEPS = 10
FINGER_OPEN_STEPS = 30
OUTER_JOINTS = [2, 3, 6, 7, 10, 11, 13, 14, 15]  # the fingers' PIP / DIP and the thumb's bends (LEAP joint order)
RISE = 0.1  # m the open hand rises off the dropped cup
# the right's let-go: the index's and the ring's MCP side joints (SPREAD_JOINTS) go to RELEASE_SPREAD (index -,
# ring +: apart) while the digits straighten and stay there as they open. The tapered small cup, its grip relaxed,
# stayed wedged between the index's and the ring's DIP links (8-16 N) as it slid and the open hand carried it off
# (seed 109; the hand moving 2 cm along -x or +x, or rising 2-3 cm, as it let go did not free it); at -0.3 / +0.3
# it drops and seats
RELEASE_SPREAD = (-0.3, 0.3)  # rad
SPREAD_JOINTS = [0, 8]
# the left moves this far (x, y, z) away once risen, clearing the right's way. With the middle cup seated where the
# large one stands (x -0.14..-0.08, 11-17 cm from the right's wrist) the open left hand was in the right arm's way:
# at (-0.05, 0.12, 0) and (-0.05, 0.2, 0) the left thumb touched the right palm, at (-0.05, 0.2, 0.1) the right
# wrist, and the small cup went down 0.5-1.5 cm off the middle cup's axis onto its rim (seed 102); at
# (-0.12, 0.25, 0) no contact and 102 succeeds
LEFT_ASIDE = (-0.12, 0.25, 0.0)


def grasp_pose(task: NestCupsHandsEnv, cup: str, side: str) -> tuple[torch.Tensor, torch.Tensor]:
    """TCP (p, q) of `side`'s top-down grasp on `cup` standing on the table."""
    n, dev = task.num_envs, task.device
    q = top_down_quat(YAW[side], n, device=dev)
    dx, dy, dz = GRASP_OFFSET
    offset = torch.tensor([[dx, -dy if side == "left" else dy, dz]], device=dev).expand(n, 3)
    p = task.cups[cup].pose.p + torch.tensor([0.0, 0.0, CUP_HEIGHT - GRASP_BELOW_RIM], device=dev)
    return p + quaternion_apply(q, offset), q


def come_down(s: HandoverSolver, task: NestCupsHandsEnv) -> dict:
    """Both hands go above their grasps, take "preshape" and come down onto them (phase 1); returns each arm's
    grasp pose."""
    grasps = {"left_arm": grasp_pose(task, "middle", "left"), "right_arm": grasp_pose(task, "small", "right")}
    s.move({a: (s.above(p, APPROACH_ABOVE), q) for a, (p, q) in grasps.items()}, max_steps=60)
    s.set_ee("left_hand", "preshape", steps=0)
    s.set_ee("right_hand", "preshape", steps=PRESHAPE_STEPS)
    s.move({a: (p, q) for a, (p, q) in grasps.items()}, max_steps=40, pos_tol=0.003)
    return grasps


def cup_grip(arm: str) -> np.ndarray:
    """`arm`'s hand's 16 joint targets on its cup: "power", the left thumb's outer bends at THUMB_BENDS."""
    grip = LEAP_SYNERGIES["power"].copy()
    if arm == "left_arm":
        grip[THUMB_OUTER_BENDS] = THUMB_BENDS
    return grip


def pick(s: HandoverSolver, task: NestCupsHandsEnv, arm: str, ee: str, cup: str, grasp) -> torch.Tensor:
    """Close `ee` on `cup` (`cup_grip`), lift it CARRY_BOTTOM clear of the table and straighten it in the grip;
    returns the arm's orientation."""
    p, q = grasp
    close_hands(s, {ee: cup_grip(arm)}, CLOSE_STEPS)
    glide(s, {arm: (p, s.above(p, CARRY_BOTTOM + LIFT_MARGIN), q)}, step_length=CARRY_STEP, settle_steps=5)
    return straighten(s, task, arm, cup)


def held_tcp(s: HandoverSolver, task: NestCupsHandsEnv, arm: str, cup: str, at: torch.Tensor) -> torch.Tensor:
    """The TCP position of `arm` that puts the held `cup`'s bottom centre at `at` (as it hangs in the grip now)."""
    return at + s.tcp(arm).p - task.cups[cup].pose.p


def straighten(s: HandoverSolver, task: NestCupsHandsEnv, arm: str, cup: str) -> torch.Tensor:
    """Turn `arm`'s TCP (about itself) by the held cup's tilt in the grip; returns the new orientation."""
    q = uprighting(task.cups[cup].pose.q, s.tcp(arm).q)
    s.move({arm: (s.tcp(arm).p.clone(), q)}, max_steps=STRAIGHTEN_STEPS)
    return q


def _hand_touches(task: NestCupsHandsEnv, arm: str, container: str) -> bool:
    """Whether `arm`'s hand presses on `container`."""
    return bool(task.ee.touches(task.cups[container], arm.split("_")[0]).any())


def _cup_touches(task: NestCupsHandsEnv, cup: str, container: str) -> bool:
    """Whether the held `cup` presses on `container`."""
    forces = contact_forces(task.scene, task.cups[container], [task.cups[cup]])
    return bool((forces.norm(dim=-1) >= TOUCH_FORCE).any())


def drop_into(s: HandoverSolver, task: NestCupsHandsEnv, arm: str, ee: str, cup: str, container: str,
              q: torch.Tensor, upright: bool = False):
    """Carry the held `cup` level over `container`, aim it closed loop, lower it until its bottom is RELEASE_BOTTOM
    over the container's floor, open the hand and rise (phases 2 and 3)."""
    dev = task.device
    high = torch.tensor([0.0, 0.0, CARRY_BOTTOM + LIFT_MARGIN], device=dev)
    start = s.tcp(arm).p.clone()
    over = held_tcp(s, task, arm, cup, task.cups[container].pose.p + high)
    glide(s, {arm: (start, over, q)}, step_length=CARRY_STEP, settle_steps=10)
    q = straighten(s, task, arm, cup)
    for _ in range(AIMS):
        s.move({arm: (held_tcp(s, task, arm, cup, task.cups[container].pose.p + high), q)}, max_steps=20,
               pos_tol=0.002)
    shape = task.shapes[container]
    low = torch.tensor([0.0, 0.0, shape.floor + RELEASE_BOTTOM], device=dev)
    steps = int(np.ceil((CARRY_BOTTOM + LIFT_MARGIN - shape.floor - RELEASE_BOTTOM) / LOWER_STEP))
    k, holds, touched = 0, 0, not upright
    while k < steps:
        # closed loop: the target keeps the held cup's axis over the container's as it goes down. With `upright`,
        # until the hand or the cup first touches the container the wrist also turns by the cup's tilt in the
        # grip every step, the descent waiting while it is tilted past HOLD_TILT; after a touch the tilt comes
        # from the contact, not the grip, and the wrist keeps its orientation. The middle cup goes down without
        # it: with it for both cups the sweep fell to 27/35 on seeds 100-134 (29/35 without), the left thumb
        # landing on the large cup's rim more often
        touched = touched or _hand_touches(task, arm, container) or _cup_touches(task, cup, container)
        if touched or bool((tilt(task.cups[cup]) <= HOLD_TILT).all()) or holds >= HOLD_STEPS:
            k += 1
        else:
            holds += 1
        if not touched:
            q = uprighting(task.cups[cup].pose.q, s.tcp(arm).q)
        at = task.cups[container].pose.p + high + (low - high) * k / steps
        s.step({arm: (held_tcp(s, task, arm, cup, at), q)})
    s.move({arm: (s.tcp(arm).p.clone(), q)}, max_steps=3)
    hand = task.agent.controller.controllers[ee].qpos.clone()
    s.close_hand(ee, hand, ramp_steps=3, hold_steps=0)
    hand[:, OUTER_JOINTS] = 0  # the digits straighten at their outer joints (unhooking the cup), then open
    opened = torch.zeros_like(hand)
    if upright:  # the small cup: the index and the ring spread apart as they straighten (RELEASE_SPREAD)
        hand[:, SPREAD_JOINTS] = opened[:, SPREAD_JOINTS] = torch.tensor(RELEASE_SPREAD, device=dev)
    s.close_hand(ee, hand, ramp_steps=RELEASE_STEPS, hold_steps=2)
    s.close_hand(ee, opened, ramp_steps=FINGER_OPEN_STEPS, hold_steps=2)
    s.move({arm: (s.above(s.tcp(arm).p.clone(), RISE), q)}, max_steps=30, pos_tol=0.02)


@register_solver("NestCupsHands", control_modes=TCP_DELTA_MODES)
def solve_nest_cups_hands(env, seed: int) -> dict:
    """Phases 1-3 of the module docstring."""
    with HandoverSolver.episode(env, seed) as s:
        task: NestCupsHandsEnv = env.unwrapped
        grasps = come_down(s, task)
        q = pick(s, task, "left_arm", "left_hand", "middle", grasps["left_arm"])
        drop_into(s, task, "left_arm", "left_hand", "middle", "large", q)
        tcp = s.tcp("left_arm").p.clone()
        tcp += torch.tensor([LEFT_ASIDE], device=tcp.device)
        s.move({"left_arm": (tcp, q)}, max_steps=20, pos_tol=0.02)
        q = pick(s, task, "right_arm", "right_hand", "small", grasps["right_arm"])
        drop_into(s, task, "right_arm", "right_hand", "small", "middle", q, upright=True)
        s.hold_until_success()
        return s.info
