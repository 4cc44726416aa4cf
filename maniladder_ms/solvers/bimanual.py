"""Two-arm solver phases on `DrivenSolver`: handing an object from one arm to the other, and lifting one
object with both arms. They go through DrivenSolver's grasp / release, so the same phases drive the
grippers of `ml_dual_panda` and the LEAP hands of `ml_dual_panda_leap`. Poses are world-frame, batched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import (axis_angle_to_matrix, matrix_to_quaternion,
                                                            quaternion_to_matrix)

from maniladder_ms.geometry import tcp_quat
from maniladder_ms.solvers.control import top_down_quat

from maniladder_ms.solvers.postures import LEAP_SYNERGIES

from .driven import APPROACH_HEIGHT, DrivenSolver

LIFT_STEP = 0.01  # metres per control step of a two-arm lift: both targets rise together
PRESHAPE_STEPS = 5  # LEAP hands take their preshape once lined up (as DrivenSolver.pick)
HAND_RAMP_STEPS, HAND_HOLD_STEPS = 40, 8  # Driver.close_hand's slow closing ramp, for several hands at once


@dataclass
class Grasp:
    """Where one arm takes hold of an object: its arm and end-effector parts, the TCP pose (p, q) of the
    grasp, and `approach`, the world offset from `p` where the arm lines up before moving straight in."""

    arm: str
    ee: str
    p: torch.Tensor
    q: torch.Tensor
    approach: torch.Tensor

    @property
    def lined_up(self) -> tuple[torch.Tensor, torch.Tensor]:
        return self.p + self.approach, self.q


def side_grasp(vessel_p: torch.Tensor, spec: dict) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(TCP p, q, palm normal) of a LEAP side grasp `spec` on an upright container standing at `vessel_p`
    (n, 3). `spec`: `yaw` of the palm normal, `pitch` (its tilt below the horizontal), `up` (+-1: which way
    the finger row runs, the TCP's y along +-z: the thumb low or high), `height` of the TCP above the
    container's floor, `shift` along the TCP's x (towards where the fingers start to curl) and `inwards`
    along the palm normal (past the axis)."""
    n, device = vessel_p.shape[0], vessel_p.device
    c = np.cos(spec["pitch"])
    pointing = torch.tensor([[c * np.cos(spec["yaw"]), c * np.sin(spec["yaw"]), -np.sin(spec["pitch"])]],
                            dtype=torch.float32, device=device).expand(n, 3)
    up = torch.tensor([[0.0, 0.0, spec["up"]]], device=device).expand(n, 3)
    q = tcp_quat(pointing, up)
    tcp_x = torch.linalg.cross(up, pointing)
    p = vessel_p + torch.tensor([0.0, 0.0, spec["height"]], device=device)
    return p - spec["shift"] * tcp_x + spec["inwards"] * pointing, q, pointing


def line_up(s: DrivenSolver, grasp: Grasp):
    """Send an arm towards its approach pose without waiting: it keeps servoing there while the solver
    runs other phases (the taker of a handover lines up while the giver picks the object)."""
    s.arm_targets[grasp.arm] = grasp.lined_up


def reach(s: DrivenSolver, grasps: list[Grasp], line_up_steps: int = 60, move_in_steps: int = 40,
          preshape: str | None = "preshape"):
    """All arms line up at their approach poses together, then move straight in to their grasp poses
    (end effectors open; LEAP hands take the synergy `preshape` once lined up, or with None keep theirs)."""
    s.move({g.arm: g.lined_up for g in grasps}, max_steps=line_up_steps)
    leap = [g.ee for g in grasps if s.is_leap(g.ee)]
    if leap and preshape is not None:
        for ee in leap:
            s.set_ee(ee, preshape, steps=0)
        for _ in range(PRESHAPE_STEPS):
            s.step()
    s.move({g.arm: (g.p, g.q) for g in grasps}, max_steps=move_in_steps, pos_tol=0.003)


def grasp_together(s: DrivenSolver, ee_parts: list[str], synergy: str = "power", ramp_steps: int = HAND_RAMP_STEPS):
    """Close several grippers / hands (LEAP hands: to `synergy` over `ramp_steps`) at once (DrivenSolver.grasp
    closes one at a time)."""
    if len(ee_parts) == 1 and synergy == "power":
        return s.grasp(ee_parts[0])
    leap = [ee for ee in ee_parts if s.is_leap(ee)]
    for ee in ee_parts:
        if ee not in leap:
            s.grip(True, ee, steps=0)
    if not leap:
        for _ in range(10):  # as DrivenSolver.grasp
            s.step()
        return
    close_hands(s, {ee: LEAP_SYNERGIES[synergy] for ee in leap}, ramp_steps)


def close_hands(s: DrivenSolver, targets: dict, ramp_steps: int = HAND_RAMP_STEPS):
    """Close LEAP hands together, each to its own 16 joint targets (`targets`: hand part -> targets), their
    commands ramping linearly over `ramp_steps`, then held `HAND_HOLD_STEPS`."""
    start = {ee: s.ee_cmd[ee].clone() for ee in targets}
    goal = {ee: torch.as_tensor(t, dtype=torch.float32, device=s.base.device) for ee, t in targets.items()}
    for k in range(1, ramp_steps + HAND_HOLD_STEPS + 1):
        for ee in targets:
            s.set_ee(ee, start[ee] + (goal[ee] - start[ee]) * min(k, ramp_steps) / ramp_steps, steps=0)
        s.step()


def hand_over(s: DrivenSolver, giver_arm: str, giver_ee: str, taker: Grasp, giver_retreat: torch.Tensor,
              release_steps: int = 5):
    """The giver holds the object still where the taker can reach it; the taker reaches its grasp and
    closes, then the giver opens and backs off by `giver_retreat` (world offset)."""
    reach(s, [taker])
    s.grasp(taker.ee)
    s.release(giver_ee, steps=release_steps)
    tcp = s.tcp(giver_arm)
    s.move({giver_arm: (tcp.p + giver_retreat, tcp.q)}, max_steps=30, pos_tol=0.02)


def glide_targets(paths: dict, step_length: float = LIFT_STEP):
    """`glide`'s targets, one {arm: (p, q)} a control step (to step through, or to run as a
    `HandoverSolver.background` while the solver moves another arm)."""
    length = max(float((end - start).norm(dim=1).max()) for start, end, _ in paths.values())
    steps = max(1, round(length / step_length))
    for k in range(1, steps + 1):
        yield {arm: (start + (end - start) * k / steps, q) for arm, (start, end, q) in paths.items()}


def glide(s: DrivenSolver, paths: dict, step_length: float = LIFT_STEP, settle_steps: int = 20):
    """Move arms along straight lines together: `paths` maps arm -> (start p, end p, q); every control step
    each target advances by its share of the way, the longest path by `step_length`, so all arrive at once."""
    for targets in glide_targets(paths, step_length):
        s.step(targets)
    s.move({arm: (end, q) for arm, (_, end, q) in paths.items()}, max_steps=settle_steps)


def follow_paths(s: DrivenSolver, paths: dict, steps: int, settle_steps: int = 5):
    """Move arms along curves together: `paths` maps arm -> (path, q), path(t) the world TCP position [B, 3]
    at t in [0, 1]; the targets advance by 1 / `steps` of the way each control step (`glide` for curves)."""
    for k in range(1, steps + 1):
        s.step({arm: (path(k / steps), q) for arm, (path, q) in paths.items()})
    s.move({arm: (path(1.0), q) for arm, (path, q) in paths.items()}, max_steps=settle_steps)


def lift_together(s: DrivenSolver, grasps: list[Grasp], height: float):
    """Both arms reach their grasps on one object, close together, and lift it by `height`: their targets
    rise together by `LIFT_STEP` a control step, so the object stays level."""
    reach(s, grasps)
    grasp_together(s, [g.ee for g in grasps])
    up = torch.tensor([0.0, 0.0, height], device=s.base.device)
    glide(s, {g.arm: (g.p, g.p + up, g.q) for g in grasps})


SET_DOWN_STEP = 0.006  # metres per control step of a two-arm set-down
RELEASE_WAIT_STEPS = 10  # control steps the opened grippers wait before rising


def carry_and_set_down(s: DrivenSolver, grasps: list[Grasp], lift: float, shift: torch.Tensor, down: float,
                       rise: torch.Tensor, carry_step: float = LIFT_STEP):
    """After `lift_together(s, grasps, lift)`: carry the object horizontally by `shift` ((n, 3) world offset,
    its z ignored) in lock-step, the targets advancing `carry_step` a control step; lower it until the grasp
    points are `down` above where they were grasped; open every end effector, wait, and rise by `rise`
    (world offset) together."""
    shift = shift.clone()
    shift[:, 2] = 0
    device = s.base.device
    up = torch.tensor([0.0, 0.0, lift], device=device)
    low = torch.tensor([0.0, 0.0, down], device=device)
    glide(s, {g.arm: (g.p + up, g.p + up + shift, g.q) for g in grasps}, step_length=carry_step)
    glide(s, {g.arm: (g.p + up + shift, g.p + shift + low, g.q) for g in grasps}, step_length=SET_DOWN_STEP)
    for g in grasps:
        s.release(g.ee, steps=0)
    for _ in range(RELEASE_WAIT_STEPS):
        s.step()
    glide(s, {g.arm: (g.p + shift + low, g.p + shift + low + rise, g.q) for g in grasps}, settle_steps=5)


def top_down_carry(s: DrivenSolver, points: dict, yaw: torch.Tensor, lift: float, shift: torch.Tensor, down: float,
                   carry_step: float = LIFT_STEP):
    """Two grippers carry one object: each arm ("left", "right": `points` maps them to world grasp points)
    takes its point top-down, fingers closing along `yaw` (either way round, whichever keeps the wrist
    nearer its neutral yaw); both lift it by `lift`, carry it by `shift` and set it down
    (`carry_and_set_down`), open and rise by half the approach height."""
    device = s.base.device
    q = top_down_quat(DrivenSolver.neutral_yaw(yaw, torch.pi), len(yaw), device)
    above = torch.tensor([0.0, 0.0, APPROACH_HEIGHT], device=device)
    grasps = [Grasp(f"{side}_arm", f"{side}_gripper", p, q, above) for side, p in points.items()]
    lift_together(s, grasps, lift)
    carry_and_set_down(s, grasps, lift, shift, down, above / 2, carry_step=carry_step)


class HandoverSolver(DrivenSolver):
    """DrivenSolver for LEAP hand-to-hand passes: the left hand (the giver) grasps with the "giver" posture; one arm
    can run along a target sequence in the background (`background`: an iterator of {arm: (p, q)}, one item a
    control step) while the solver's phases move the other arm; `move` then waits only for the arms it was given."""

    background = None

    def grasp(self, ee_part: str):
        if ee_part == "left_hand":
            self.close_hand(ee_part, "giver")
        else:
            super().grasp(ee_part)

    def step(self, targets: dict | None = None, base_vel=None):
        if self.background is not None:
            try:
                self.arm_targets.update(next(self.background))
            except StopIteration:
                self.background = None
        return super().step(targets, base_vel)

    def move(self, targets: dict, max_steps: int = 60, pos_tol: float = 0.005, rot_tol: float = 0.03):
        for _ in range(max_steps):
            errs = self.step(targets)
            if all(bool((errs[a][0] < pos_tol).all() and (errs[a][1] < rot_tol).all()) for a in targets):
                break
        return self.last


def roll_targets(s: DrivenSolver, arm: str, yaw: float, roll_sign: float, end: torch.Tensor, waypoints: int,
                 steps_per_waypoint: int):
    """A background sequence turning a top-down hand (yaw `yaw`) palm-up: `waypoints` equal rolls about its
    TCP y axis (sense `roll_sign`) while its TCP moves in a straight line to `end`, `steps_per_waypoint`
    control steps each, so the arm's differential IK follows (one 180-degree target it does not reach)."""
    n = s.base.num_envs
    r0 = quaternion_to_matrix(top_down_quat(yaw, n, device=s.base.device))
    axis = r0[:, :, 1]
    p0 = s.tcp(arm).p.clone()
    for k in range(1, waypoints + 1):
        t = k / waypoints
        rk = axis_angle_to_matrix(axis * roll_sign * np.pi * t) @ r0
        for _ in range(steps_per_waypoint):
            yield {arm: (p0 + (end - p0) * t, matrix_to_quaternion(rk))}
