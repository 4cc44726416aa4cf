"""Scripted solver of HangTowelOnHookHands (tasks/cloth/hang_towel_on_hook_hands.py): both LEAP hands
lift the towel by two opposite corners, the right one (the loop's corner) turns the loop's ring across the hook's
shaft, both carry the ring over the hook's tip, and the hands let go one after the other.

1. Pinch: each hand scissor-pinches the corner on its side (`solvers.towel.pinch_side_corners`, as
   LiftTowelHands); the right hand's fingers take the loop's corner with the ring's first beads.
2. Lift: both rise together until the TCPs are `LIFT_ABOVE_TIP` over the hook's tip.
3. Turn: the right hand turns about the vertical until the ring's plane faces the shaft (its normal's yaw 0
   modulo pi), `TURN_TRIES` times, closed loop on the ring's particles.
4. Line up: both hands move together until the ring's centre is `FRONT` in front of the tip (towards the robot,
   at the tip's height), `LINE_UP_TRIES` times, closed loop.
5. Thread: both move `FRONT + THREAD_IN` along +x: the shaft goes through the ring. Where the ring is not on
   the hook then (`cloth.loop_on_hook`, the shaft pushed a bead aside), both back out, the ring is turned again
   and phases 4-5 repeat, `THREAD_TRIES` times in all.
6. Right lets go: lowers `DROP` (the ring's top down onto the shaft), opens and rises `RISE`.
7. Left lets go: moves its corner to `LEFT_SIDE` beside the hook and `LEFT_DOWN` lower (the towel hangs under the
   hook), opens and backs off `BACK_OFF`.
"""

from __future__ import annotations

import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_multiply

from maniladder_ms.deformables import cloth
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import Grasp, glide
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.towel import pinch_side_corners
from maniladder_ms.tasks.cloth.hang_towel_on_hook_hands import HangTowelOnHookHandsEnv

LIFT_ABOVE_TIP = 0.09  # TCP height over the hook's tip after the lift: the ring hangs ~3 cm under the TCP
LIFT_STEP, MOVE_STEP, THREAD_STEP, DROP_STEP = 0.008, 0.008, 0.005, 0.004  # metres per control step
TURN_TRIES, TURN_STEPS, TURN_SETTLE = 2, 60, 10  # the ring's turn: tries, steps each, steps to settle after
# the turn is the one of the two (pi apart) that keeps the arm's Panda joint 7 (limits +-2.8973 rad) this far inside
# its range: after the pinch the right arm's joint 7 sits at ~2.87 rad (seed 103: the nearer turn drove it into the
# limit and the ring stayed 2 cm off the tip); a top-down hand turned by +a about the vertical moves joint 7 by -a
JOINT7_LIMIT, JOINT7_MARGIN = 2.8973, 0.15
LINE_UP_TRIES = 3
THREAD_TRIES = 3
FRONT = 0.04  # the ring's centre lined up this far in front of the tip
THREAD_IN = 0.055  # and carried this far past it along x (of the 7.5 cm the shaft reaches out in x)
DROP = 0.015  # the right hand lowers this much before opening: the ring's top comes down onto the shaft
OPEN_STEPS = 12
RISE = 0.06  # the opened right hand rises this much, straight up, clear of the ring
LEFT_SIDE, LEFT_DOWN = 0.08, 0.1  # the left corner goes this far (+y) beside the hook and this much lower
BACK_OFF = (-0.04, 0.0, 0.04)  # the opened left hand's move away from the towel


def ring_centre(task: HangTowelOnHookHandsEnv) -> torch.Tensor:
    """The mean of the loop's ring particles, [B, 3]."""
    return task.towel.positions()[:, task.ring].mean(dim=1)


def ring_normal_yaw(task: HangTowelOnHookHandsEnv) -> torch.Tensor:
    """Yaw of the normal of the ring's best-fit plane, [B] (modulo pi)."""
    ring = task.towel.positions()[:, task.ring]
    _, _, vt = torch.linalg.svd(ring - ring.mean(dim=1, keepdim=True))
    normal = vt[:, 2]
    return torch.atan2(normal[:, 1], normal[:, 0])


def turn_ring(s: DrivenSolver, task: HangTowelOnHookHandsEnv, grasp: Grasp, active: torch.Tensor) -> Grasp:
    """Turn the hand of `grasp` about the vertical until the ring's normal points along x (phase 3), where
    `active` [B]; returns the grasp with the new orientation."""
    q = grasp.q
    robot = task.agent.robot
    joint7 = [j.name for j in robot.get_active_joints()].index(f"{grasp.arm.split('_')[0]}_panda_joint7")
    for _ in range(TURN_TRIES):
        turn = torch.remainder(-ring_normal_yaw(task) + torch.pi / 2, torch.pi) - torch.pi / 2  # nearest 0 or pi
        q7 = robot.get_qpos()[:, joint7]
        reach = JOINT7_LIMIT - JOINT7_MARGIN
        turn = torch.where(q7 - turn > reach, turn + torch.pi, torch.where(q7 - turn < -reach, turn - torch.pi, turn))
        q = quaternion_multiply(yaw_quat(turn * active), q)
        s.move({grasp.arm: (s.tcp(grasp.arm).p.clone(), q)}, max_steps=TURN_STEPS)
        for _ in range(TURN_SETTLE):
            s.step()
    return Grasp(grasp.arm, grasp.ee, grasp.p, q, grasp.approach)


def on_hook(task: HangTowelOnHookHandsEnv) -> torch.Tensor:
    """[B] bool: the ring is on the hook now (the task's `cloth.loop_on_hook`)."""
    return cloth.loop_on_hook(task.towel.positions(), task.ring, task.hook_tip(), task.hook_axis, task.hook_length)


def move_both(s: DrivenSolver, grasps: list[Grasp], shift: torch.Tensor, step_length: float, settle_steps: int = 5):
    """Glide both hands by `shift` [B, 3] from where they are, keeping their orientations."""
    glide(s, {g.arm: (s.tcp(g.arm).p.clone(), s.tcp(g.arm).p + shift, g.q) for g in grasps},
          step_length=step_length, settle_steps=settle_steps)


@register_solver("HangTowelOnHookHands", control_modes=TCP_DELTA_MODES)
def solve_hang_towel_on_hook_hands(env, seed: int) -> dict:
    """The phases of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: HangTowelOnHookHandsEnv = env.unwrapped
        device = task.device
        grasps = pinch_side_corners(s, task.towel, task.hand_corners)
        tip = task.hook_tip()
        paths = {}
        for g in grasps.values():
            top = g.p.clone()
            top[:, 2] = tip[:, 2] + LIFT_ABOVE_TIP
            paths[g.arm] = (g.p, top, g.q)
        glide(s, paths, step_length=LIFT_STEP)
        front = tip - torch.tensor([FRONT, 0.0, 0.0], device=device)
        through = torch.tensor([[FRONT + THREAD_IN, 0.0, 0.0]], device=device)
        missed = torch.ones(task.num_envs, dtype=torch.bool, device=device)
        for attempt in range(THREAD_TRIES):
            if attempt:  # back out where the ring missed
                move_both(s, list(grasps.values()), -through * missed[:, None], MOVE_STEP)
            grasps["right"] = turn_ring(s, task, grasps["right"], missed)
            both = list(grasps.values())
            for _ in range(LINE_UP_TRIES):
                move_both(s, both, (front - ring_centre(task)) * missed[:, None], MOVE_STEP)
            move_both(s, both, through * missed[:, None], THREAD_STEP)
            missed &= ~on_hook(task)
            if not bool(missed.any()):
                break
        right, left = grasps["right"], grasps["left"]
        p = s.tcp(right.arm).p.clone()
        glide(s, {right.arm: (p, p - torch.tensor([0.0, 0.0, DROP], device=device), right.q)},
              step_length=DROP_STEP, settle_steps=2)
        s.set_ee(right.ee, "scissor_open", steps=OPEN_STEPS)
        p = s.tcp(right.arm).p.clone()
        glide(s, {right.arm: (p, p + torch.tensor([0.0, 0.0, RISE], device=device), right.q)},
              step_length=LIFT_STEP, settle_steps=2)
        p = s.tcp(left.arm).p.clone()
        beside = p.clone()
        beside[:, 1] = tip[:, 1] + LEFT_SIDE
        beside[:, 2] -= LEFT_DOWN
        glide(s, {left.arm: (p, beside, left.q)}, step_length=MOVE_STEP, settle_steps=5)
        s.set_ee(left.ee, "scissor_open", steps=OPEN_STEPS)
        glide(s, {left.arm: (beside, beside + torch.tensor(BACK_OFF, device=device), left.q)},
              step_length=MOVE_STEP, settle_steps=2)
        s.hold_until_success()
        return s.info
