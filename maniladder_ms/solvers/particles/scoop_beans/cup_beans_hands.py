"""Scripted solver of CupBeansHands (tasks/particles/scoop_beans/cup_beans_hands.py): the right's cupped palm waits
under the ledge's overhanging edge while the left, flat as a blade, sweeps the beans off into it; the right carries
them towards the cup while the left picks the cup up and holds it; the right tips them in off its fingers.

1. the right rolls palm-up (in the background) to CATCH_APPROACH in front of its catch pose, while the left, open
   as a blade, goes BLADE_WAIT_ABOVE over its start at the ledge's far wall;
2. the right takes "cup" and moves in under the ledge's edge (`catch_point`, tilted PALM_TILT);
3. the left comes down to the floor, sweeps the pile BLADE_SWEEP towards -y off the edge into the palm, waits
   SWEEP_SETTLE_STEPS and retreats +y while it lifts;
4. the right backs BACK_OFF away from the ledge and carries its load CARRY towards -x;
5. in the background, the right backs out further, rises and carries its load until its lip (POUR_LIP) is over
   where the held cup will be (`carry_palm_to_cup`), while
6. the left moves clear of the ledge, side-grasps the cup (`solvers.side_grasps`), lifts it and carries it in two
   legs to CUP_HOLD_AT (`left_takes_cup`);
7. the right tilts its palm fingertips-down to POUR_TILT about its lip over the held cup's measured rim, the middle
   finger opening flat (`pour_palm_into_cup`), and holds until the beans are in.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import (axis_angle_to_matrix, matrix_to_quaternion, quaternion_apply,
                                                            quaternion_to_matrix)

from maniladder_ms.agents.effectors import leap_fingertip

from maniladder_ms.solvers.control import top_down_quat

from maniladder_ms.solvers.postures import LEAP_SYNERGIES
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.bimanual import HandoverSolver, close_hands, glide, glide_targets, roll_targets
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.side_grasps import LEFT_THUMB_LOW_GRASP, LINE_UP_ABOVE, SIDE_PRESHAPE_STEPS, lined_up_side_grasp
from maniladder_ms.tasks.particles.scoop_beans.cup_beans_hands import (TRAY_FLOOR, TRAY_INNER, TRAY_WALL,
                                                                       CupBeansHandsEnv)

# ---- the right's palm-up pose ----------------------------------------------------------------------------------
# HandoverBallHands' roll: top-down yaw -90 deg rolled half a turn about its TCP y axis, sign -1: palm-up, fingers +y;
# tilted `PALM_TILT` about the TCP y axis (+: fingertips down, the heel up)
PALM_UP_YAW, PALM_UP_ROLL_SIGN = -np.pi / 2, -1.0
PALM_TILT = np.deg2rad(10.0)  # also under the ledge, where it caught 20/25/22 beans against 26/11/12 level
# the cupped palm the right carries beans in (LEAP_SYNERGIES["cup"]: 36 of 40 beans kept on a palm-up hand through a
# 20 cm carry)
CUP_SYNERGY = LEAP_SYNERGIES["cup"]
CARRY_STEP = 0.003  # m per control step with the loaded palm

# ---- the sweep and catch -----------------------------------------------------------------------------------------
# the right rolls palm-up (HandoverBallHands' roll: 12 waypoints of 15 degrees, 8 steps each; `palm_up_quat`'s yaw and
# sense, fingers +y) to a point CATCH_APPROACH in front of (-y) its catch pose, then moves in level
CATCH_ROLL_WAYPOINTS, CATCH_ROLL_STEPS = 12, 8
CATCH_APPROACH = 0.06
# the catch pose (tray frame, from the slab's -y edge and the floor's top): palm-up the TCP goes no lower than ~0.34
# (floor - 0.035 at a 38 cm floor); the TCP 7.8 cm in front of the edge puts the cupped tips ~2 cm under the slab
CATCH_X, CATCH_FROM_EDGE, CATCH_BELOW_FLOOR = 0.03, -0.078, -0.035
# the left hand as a blade: palm normal -y, fingers straight down (closing along +x), open with the side joints 0.1
# towards the middle finger; its middle tip starts at the tray's x, BLADE_FROM_FAR_WALL in front of the far wall,
# BLADE_OVER_FLOOR over the floor, and sweeps BLADE_SWEEP in -y at BLADE_STEP a step (to 0.8 cm past the lip's inner
# face: 1.5 cm lost half the catch as the left lifted off), comes down from BLADE_ABOVE over the start
BLADE_HAND = [0.1, 0, 0, 0, 0, 0, 0, 0, -0.1, 0, 0, 0, 0, 0, 0, 0]
BLADE_FROM_FAR_WALL, BLADE_OVER_FLOOR, BLADE_ABOVE = 0.01, 0.003, 0.1
BLADE_WAIT_ABOVE = 0.2  # the blade waits this far over its start while the right rolls under the ledge
BLADE_SWEEP, BLADE_STEP = 0.128, 0.003
SWEEP_SETTLE_STEPS = 20  # held at the sweep's end while the beans come to rest in the palm
# the left then retreats +y while it lifts (lifting straight up took half the catch off): per step, steps
RETREAT_STEP, RETREAT_STEPS = (0.0, 0.005, 0.005), 20
# the right backs away from the ledge (-y) slowly, then carries the load -x towards the cup
BACK_OFF, BACK_OFF_STEP = 0.03, 0.0015
CARRY = 0.12  # the carry away from the ledge, at CARRY_STEP

# ---- the carry to the pour point and the cup's grasp ---------------------------------------------------------------
# where the beans leave the hand: over the middle fingertip's pad, TCP frame (x along the fingers, z out of the palm)
POUR_LIP = (0.14, 0.03, -0.06)
POUR_LIP_APPROACH = 0.06  # the lip this far above the held cup's rim when the loaded palm arrives
# the lip this far past the cup's axis along the fingers (+y): before it, just inside the near rim, so that the
# beans sliding off the tips fall into the 7 cm mouth before they fly past the far rim (at the axis and 3 cm over
# the rim, seed 100: 1 of 21 in the cup, the rest 10-38 cm past it)
POUR_LIP_PAST_AXIS = -0.025
# from under the ledge: first straight back (-y) until the fingertips are out in front of its edge (m, m per
# control step); then straight up, then level to the cup
BACK_OUT, BACK_OUT_STEP = 0.06, 0.002
# the left's side grasp of the cup: the left hand's measured thumb-low grasp (PourGrainsHandToCup's glass), here on
# the wider cup (outer radius 3.9 cm, the glass 2.9)
CUP_GRASP = LEFT_THUMB_LOW_GRASP
CUP_LIFT = 0.1  # straight up after the close
# from the sweep's end (the blade pose over the ledge) the left first moves level this far +y, turning to the side
# grasp, clear of the ledge before it descends to the cup (a direct move drops the saturated z first)
LEFT_CLEAR_Y = 0.15
# where the left holds the cup for the pour: its axis at (x, y), -x of the ledge's stand, its bottom this high
CUP_HOLD_AT, CUP_HOLD_BOTTOM = (-0.20, -0.03), 0.15
CUP_CARRY_STEP = 0.01  # m per control step carrying the held cup

# ---- the pour ------------------------------------------------------------------------------------------------------
# the lip this far above the held cup's rim at the end of the tilt: at 1-2 cm the lowered fingertips press the near
# rim (the held cup pushed 0.5-3.5 cm down in the grasp) for about one more bean delivered; at 3 cm no touch
POUR_LIP_OVER_RIM = 0.03
POUR_TILT, POUR_TILT_STEPS, POUR_HOLD_STEPS = np.deg2rad(60.0), 90, 30
POUR_HAND = LEAP_SYNERGIES["pour_flat"]


def palm_up_quat(n: int, device, tilt: float = PALM_TILT) -> torch.Tensor:
    """(n, 4) wxyz TCP orientation of the right hand palm-up, fingers +y, tilted `tilt` rad fingertips-down."""
    r0 = quaternion_to_matrix(top_down_quat(PALM_UP_YAW, n, device=device))
    up = axis_angle_to_matrix(r0[:, :, 1] * PALM_UP_ROLL_SIGN * np.pi) @ r0
    return matrix_to_quaternion(axis_angle_to_matrix(up[:, :, 1] * tilt) @ up)


def catch_point(task: CupBeansHandsEnv) -> torch.Tensor:
    """The right TCP's catch position under the ledge's -y edge (the slab's edge: the lip's outer face)."""
    tray = task.tray.pose.p
    edge = tray[:, 1] - TRAY_INNER[1] - TRAY_WALL
    return torch.stack([tray[:, 0] + CATCH_X, edge + CATCH_FROM_EDGE, tray[:, 2] + TRAY_FLOOR + CATCH_BELOW_FLOOR], 1)


def blade_pose(task: CupBeansHandsEnv) -> torch.Tensor:
    """(n, 4) the left TCP's orientation as a blade: palm normal -y, fingers straight down, closing along +x."""
    n = task.num_envs
    return tcp_quat(torch.tensor([[0.0, -1.0, 0.0]], device=task.device).expand(n, 3),
                    torch.tensor([[1.0, 0.0, 0.0]], device=task.device).expand(n, 3))


def sweep_and_catch(s: DrivenSolver, task: CupBeansHandsEnv):
    """The right rolls palm-up into "cup" and comes under the ledge's edge; the left, a blade, sweeps the pile off
    the ledge into it, retreats +y while it lifts; the right backs away and carries the load CARRY towards -x."""
    dev, n = task.device, task.num_envs
    # right: roll palm-up to the approach point in the background
    tray = task.tray.pose.p
    approach = catch_point(task) - torch.tensor([0.0, CATCH_APPROACH, 0.0], device=dev)
    s.background = roll_targets(s, "right_arm", PALM_UP_YAW, PALM_UP_ROLL_SIGN, approach, CATCH_ROLL_WAYPOINTS,
                                CATCH_ROLL_STEPS)
    # left: the blade over its start, while the right rolls
    bq = blade_pose(task)
    far = tray[:, 1] + TRAY_INNER[1] - BLADE_FROM_FAR_WALL
    tip_start = torch.stack([tray[:, 0], far, tray[:, 2] + TRAY_FLOOR + BLADE_OVER_FLOOR], 1)
    s.set_ee("left_hand", BLADE_HAND, steps=0)
    s.move({"left_arm": (tip_start + torch.tensor([0.0, 0.0, BLADE_WAIT_ABOVE], device=dev), bq)}, max_steps=80,
           pos_tol=0.01)
    while s.background is not None:
        s.step()
    cp, cq = catch_point(task), palm_up_quat(n, dev)  # palm up, tilted PALM_TILT: the normal leans to the ledge (+y)
    s.set_ee("right_hand", CUP_SYNERGY, steps=0)
    s.move({"right_arm": (approach, cq)}, max_steps=40, pos_tol=0.005)
    s.move({"right_arm": (cp, cq)}, max_steps=40, pos_tol=0.003)
    # the blade's middle tip from its TCP, measured in the air
    offset = leap_fingertip(task.agent, "middle", "left_") - s.tcp("left_arm").p
    start = tip_start - offset
    s.move({"left_arm": (start + torch.tensor([0.0, 0.0, BLADE_ABOVE], device=dev), bq)}, max_steps=40, pos_tol=0.005)
    glide(s, {"left_arm": (s.tcp("left_arm").p.clone(), start, bq)}, step_length=BLADE_STEP, settle_steps=10)
    end = start - torch.tensor([0.0, BLADE_SWEEP, 0.0], device=dev)
    glide(s, {"left_arm": (start, end, bq)}, step_length=BLADE_STEP, settle_steps=0)
    for _ in range(SWEEP_SETTLE_STEPS):
        s.step()
    step = torch.tensor(RETREAT_STEP, device=dev)
    glide(s, {"left_arm": (end, end + RETREAT_STEPS * step, bq)}, step_length=float(step.norm()), settle_steps=0)
    back = cp - torch.tensor([0.0, BACK_OFF, 0.0], device=dev)
    glide(s, {"right_arm": (cp, back, cq)}, step_length=BACK_OFF_STEP, settle_steps=0)
    carried = back - torch.tensor([CARRY, 0.0, 0.0], device=dev)
    glide(s, {"right_arm": (back, carried, cq)}, step_length=CARRY_STEP, settle_steps=10)


def cup_hold_rim(task: CupBeansHandsEnv) -> torch.Tensor:
    """(n, 3) the centre of the held cup's mouth where `left_takes_cup` brings it."""
    rim = torch.tensor([[*CUP_HOLD_AT, CUP_HOLD_BOTTOM + task.cup_shape.inner[-1][0]]], device=task.device)
    return rim.expand(task.num_envs, 3)


def carry_palm_to_cup(s: DrivenSolver, task: CupBeansHandsEnv):
    """Targets, one item a control step ({"right_arm": (p, q)}; run as a `HandoverSolver.background` while the left
    takes the cup): the loaded palm-up right hand backs straight out from under the ledge (-y), rises to the pour
    height and carries its beans level until its lip (`POUR_LIP`) is `POUR_LIP_APPROACH` above where the held cup's
    rim will be (`cup_hold_rim`), `POUR_LIP_PAST_AXIS` along +y."""
    n, dev = task.num_envs, task.device
    q = palm_up_quat(n, dev)
    over = cup_hold_rim(task) + torch.tensor([0.0, POUR_LIP_PAST_AXIS, POUR_LIP_APPROACH], device=dev)
    arrive = over - quaternion_apply(q, torch.tensor([POUR_LIP], device=dev).expand(n, 3))
    start = s.tcp("right_arm").p.clone()
    back = start - torch.tensor([0.0, BACK_OUT, 0.0], device=dev)
    up = back.clone()
    up[:, 2] = arrive[:, 2]
    for a, b, step_length in ((start, back, BACK_OUT_STEP), (back, up, CARRY_STEP), (up, arrive, CARRY_STEP)):
        yield from glide_targets({"right_arm": (a, b, q)}, step_length)


def left_takes_cup(s: DrivenSolver, task: CupBeansHandsEnv):
    """From the sweep's end over the ledge, the left moves level `LEFT_CLEAR_Y` away (+y) turning to its side grasp,
    goes above the line-up point for it beside the cup, comes in, closes, lifts the cup and carries it upright to
    `CUP_HOLD_AT`."""
    grasp, _ = lined_up_side_grasp("left_arm", "left_hand", task.cup.pose.p, CUP_GRASP)
    (p, q), (lined_up, _) = (grasp.p, grasp.q), grasp.lined_up
    clear = s.tcp("left_arm").p + torch.tensor([0.0, LEFT_CLEAR_Y, 0.0], device=task.device)
    s.move({"left_arm": (clear, q)}, max_steps=40, pos_tol=0.02)
    s.move({"left_arm": (s.above(lined_up, LINE_UP_ABOVE), q)}, max_steps=80, pos_tol=0.01)
    s.set_ee("left_hand", CUP_GRASP["approach"], steps=SIDE_PRESHAPE_STEPS)
    s.move({"left_arm": (lined_up, q)}, max_steps=60)
    s.move({"left_arm": (p, q)}, max_steps=40, pos_tol=0.003)
    close_hands(s, {"left_hand": CUP_GRASP["close"]})
    s.move({"left_arm": (s.above(p, CUP_LIFT), q)}, max_steps=30)
    held = s.tcp("left_arm").p - task.cup.pose.p  # the TCP from the cup's bottom centre, as held
    goal = torch.tensor([[*CUP_HOLD_AT, CUP_HOLD_BOTTOM]], device=task.device) + held
    # in two legs, along x to the goal's x (and height), then along y: a straight line took the cup onto the ledge's
    # stand's +y / -x corner, where it stuck 7 cm short (seed 101: 0 delivered; in two legs 20, seed 100 6 -> 23)
    start = s.tcp("left_arm").p.clone()
    corner = torch.cat([goal[:, :1], start[:, 1:2], goal[:, 2:]], dim=1)
    glide(s, {"left_arm": (start, corner, q)}, step_length=CUP_CARRY_STEP, settle_steps=0)
    glide(s, {"left_arm": (corner, goal, q)}, step_length=CUP_CARRY_STEP)


def pour_palm_into_cup(s: DrivenSolver, task: CupBeansHandsEnv):
    """The loaded right palm, brought over the cup by `carry_palm_to_cup`, tilts fingertips-down to `POUR_TILT`
    about its lip, the lip going from `POUR_LIP_APPROACH` to `POUR_LIP_OVER_RIM` above the held cup's measured rim,
    `POUR_LIP_PAST_AXIS` from its axis; the middle finger opens flat meanwhile (`POUR_HAND`)."""
    n, dev = task.num_envs, task.device
    lip = torch.tensor([POUR_LIP], device=dev).expand(n, 3)
    q0 = palm_up_quat(n, dev)
    s.move({"right_arm": (s.arm_targets["right_arm"][0], q0)}, max_steps=10)
    rim = task.cup.pose.p[:, 2] + task.cup_shape.inner[-1][0]
    over = task.cup.pose.p.clone()
    over[:, 1] += POUR_LIP_PAST_AXIS
    over[:, 2] = rim + POUR_LIP_APPROACH
    start = s.tcp("right_arm").p + quaternion_apply(q0, lip)  # the lip, where it is
    end = over.clone()
    end[:, 2] = rim + POUR_LIP_OVER_RIM
    cupped = s.ee_cmd["right_hand"].clone()
    flat = torch.as_tensor(POUR_HAND, dtype=torch.float32, device=dev)
    for k in range(1, POUR_TILT_STEPS + POUR_HOLD_STEPS + 1):
        f = min(k, POUR_TILT_STEPS) / POUR_TILT_STEPS
        q = palm_up_quat(n, dev, PALM_TILT + (POUR_TILT - PALM_TILT) * f)
        s.set_ee("right_hand", cupped + (flat - cupped) * f, steps=0)
        s.step({"right_arm": (start + (end - start) * f - quaternion_apply(q, lip), q)})


@register_solver("CupBeansHands", control_modes=TCP_DELTA_MODES)
def solve_cup_beans_hands(env, seed: int) -> dict:
    """The right's cupped palm under the ledge's edge, the left sweeps the beans into it (`sweep_and_catch`); the
    right carries them to the pour point in the background (`carry_palm_to_cup`) while the left takes the cup and
    holds it there (`left_takes_cup`); the right tips them in (`pour_palm_into_cup`)."""
    with HandoverSolver.episode(env, seed) as s:
        task: CupBeansHandsEnv = env.unwrapped
        sweep_and_catch(s, task)
        s.background = carry_palm_to_cup(s, task)
        left_takes_cup(s, task)
        while s.background is not None:
            s.step()
        pour_palm_into_cup(s, task)
        s.hold_until_success()
        return s.info
