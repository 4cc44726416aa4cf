"""Closed-loop TCP solvers for every agent (`pd_ee_delta_pose` through `solvers.control.Driver`).

The LEAP hands and the dual-arm agents have no motion planner here; their task solvers servo TCP
targets with `DrivenSolver` and compose its phases: top-down picks with a gripper or a hand's power
grasp, lifts, releases. All targets are world-frame, batched over the env's sub-scenes.
"""

from __future__ import annotations

from typing import Callable

import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.solvers.control import Driver, top_down_quat

from .base import SolverBase

APPROACH_HEIGHT = 0.1  # metres above a grasp where the vertical descent starts
# where a held rope capsule's centre sits in the tcp frame of a top-down LEAP hand in the "scissor" pinch
# (fingers along the rope): between the index and middle fingertips (measured on their collision boxes:
# 1.65 cm out along the fingers, the middle of the tips' width; 0.7 cm to the middle finger's side, the
# middle of the gap between the spread tips; the left hand mirrors it), 3.6 cm below the tcp, which keeps
# the tips' ends ~3 mm above the table when the capsule lies on it
SCISSOR_OFFSET = (0.0165, 0.007, 0.036)
# a cloth corner particle in the scissor pinch: the tips' middle this far outwards of it along the sheet's
# diagonal, so the tips' inner ends (3.5 cm along the diagonal) stop 1-3 mm short of the corner's two edge
# neighbours (DragTowelHand, with the first, saturating scissor targets: the same 18/20 seeds at 2, 5 and 8 mm)
CORNER_OUTSET = 0.005
# control steps over which a LEAP hand swings into the "scissor" pinch (1 s): on LiftRopeHand 8/10 seeds held
# at 20 steps, 4/5 at 40
SCISSOR_RAMP_STEPS = 20


class DrivenSolver(SolverBase, Driver):
    """`Driver` plus the phases task solvers share (`SolverBase`: `episode`, `info`, `hold_until_success`)."""

    def is_leap(self, ee_part: str) -> bool:
        return ee_part.endswith("hand")

    @staticmethod
    def neutral_yaw(yaw: torch.Tensor, period: float) -> torch.Tensor:
        """Of the grasp yaws equivalent to `yaw` modulo `period` (a symmetric object or gripper), the one
        nearest 0, the rest pose's: the wrist stays mid-range (the yaw nearest the current TCP can
        lie past a joint limit after a tilted move)."""
        return torch.remainder(yaw + period / 2, period) - period / 2

    @staticmethod
    def scissor_pose(centre: torch.Tensor, yaw: torch.Tensor, mirror: bool = False, around: float = 0.0):
        """TCP pose (p, q) of a top-down LEAP hand whose "scissor" pinch closes on a rope capsule centred at
        `centre` (n, 3) and lying along world yaw `yaw` (n,) (of the two hand yaws, the one nearest `around`:
        0 for a single arm, the way an arm of a dual-arm robot points across the table for it); `mirror`
        for a left hand."""
        n = centre.shape[0]
        q = top_down_quat(DrivenSolver.neutral_yaw(yaw - around, torch.pi) + around, n, device=centre.device)
        x, y, z = SCISSOR_OFFSET
        offset = torch.tensor([x, -y if mirror else y, z], device=centre.device).expand(n, 3)
        return centre - quaternion_apply(q, offset), q

    @staticmethod
    def corner_scissor_pose(corner: torch.Tensor, sheet_centre: torch.Tensor, radius: float, mirror: bool = False,
                            around: float = 0.0):
        """TCP pose (p, q) of a top-down LEAP hand whose "scissor" pinch closes on a cloth corner particle
        at `corner` (n, 3) of a sheet centred at `sheet_centre` (n, 3); `radius`: the particle's. The
        fingers lie along the sheet's diagonal, their tips' middle `CORNER_OUTSET` outwards of the corner;
        `mirror`, `around`: as `scissor_pose`."""
        outwards = corner - sheet_centre
        outwards[:, 2] = 0
        outwards = torch.nn.functional.normalize(outwards, dim=1)
        centre = corner + outwards * CORNER_OUTSET
        centre[:, 2] = radius
        return DrivenSolver.scissor_pose(centre, torch.atan2(outwards[:, 1], outwards[:, 0]), mirror, around)

    def above(self, p: torch.Tensor, height: float) -> torch.Tensor:
        return p + torch.tensor([0.0, 0.0, height], device=p.device)

    def pick(self, arm: str, ee_part: str, center: torch.Tensor, yaw, lift: float = 0.1,
             approach: float = APPROACH_HEIGHT):
        """Top-down grasp at `center` (the TCP goes there: a gripper's finger centre, a LEAP hand's power
        grasp centre), fingers closing across `yaw`; then lift by `lift`."""
        q = top_down_quat(yaw, self.base.num_envs, device=center.device)
        self.release(ee_part, steps=1)
        self.move({arm: (self.above(center, approach), q)}, max_steps=60)
        if self.is_leap(ee_part):  # thumb under the palm only once above the object (it sweeps objects over)
            self.set_ee(ee_part, "preshape", steps=5)
        self.move({arm: (center, q)}, max_steps=40, pos_tol=0.003)
        self.grasp(ee_part)
        if lift:
            self.move({arm: (self.above(center, lift), q)}, max_steps=40)

    def grasp(self, ee_part: str):
        if self.is_leap(ee_part):
            self.close_hand(ee_part, "power")
        else:
            self.grip(True, ee_part, steps=10)

    def release(self, ee_part: str, steps: int = 10):
        if self.is_leap(ee_part):
            self.set_ee(ee_part, "open", steps=steps)
        else:
            self.grip(False, ee_part, steps=steps)

    def follow_arc(self, arm: str, q: torch.Tensor, angle: Callable[[], torch.Tensor],
                   tcp_at: Callable[[torch.Tensor], torch.Tensor], lead: float, stop_at: float, max_steps: int):
        """Drive a part round its arc closed loop (a lid about its hinge, a book about its edge): every
        control step read the part's `angle()` (b,) and send the TCP to `tcp_at(angle + lead)`, keeping
        orientation `q`, until the angle reaches `stop_at` everywhere. Aiming ahead by `lead` makes the
        fingers push the part along instead of trailing it."""
        for _ in range(max_steps):
            now = angle()
            if bool((now >= stop_at).all()):
                return
            self.step({arm: (tcp_at(now + lead), q)})

    def hold_still(self):
        self.step()
