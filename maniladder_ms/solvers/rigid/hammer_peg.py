"""Scripted solver of HammerPeg (tasks/rigid/hammer_peg.py): grasp the hammer's handle near the head, carry the head
over the peg and strike the peg's top again and again until it is flush, closed loop on the measured striking face
(the hammer shifts in the grip at every blow).

1. Pick: grasp the handle top-down `GRASP_FROM_HEAD` from the head's centre, fingers across it, `GRASP_ABOVE`
   above the handle's middle height; lift by `LIFT`.
2. Aim: servo the striking face's centre `RAISE` above the peg's top (at most `AIM_STEPS` control steps, done
   within `AIM_TOL`).
3. Strike: for `STRIKE_STEPS` control steps send the face's target `FOLLOW_THROUGH` below the peg's top (the
   controller's largest step down: the head lands at ~0.6 m/s); the next aim leads by the landing's horizontal
   offset (`LEAD_GAIN`, at most `MAX_LEAD`); back to 2 until the peg is at most
   `FLUSH_MARGIN` proud of the board (at most `MAX_BLOWS` blows).
4. Lift the hammer clear by `CLEAR`; hold until success.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.tasks.rigid.hammer_peg import HammerPegEnv

GRASP_FROM_HEAD = 0.07  # m from the head's centre along the handle: the fingers clear of the head and the board
GRASP_ABOVE = 0.004  # m above the handle's middle height (the hammer slides up in the fingers at each blow)
LIFT = 0.12  # m the hammer is lifted after the grasp
RAISE = 0.06  # m of the striking face above the peg's top before a blow (from here it lands at 0.6-0.7 m/s)
AIM_STEPS, AIM_TOL = 20, 0.004  # the aim's step budget and its tolerance (m, face to its target)
FOLLOW_THROUGH = 0.03  # m below the peg's top the face is sent during a blow (seeds 100-109: 2-16 mm a blow)
STRIKE_STEPS = 3  # control steps of a blow (the head lands in the third; a fourth only pushes)
LEAD_GAIN = 1.0  # of a landing's horizontal offset taken off the next blow's aim
MAX_LEAD = 0.02  # m, the largest lead per horizontal axis
FLUSH_MARGIN = 0.002  # m: the blows stop once the peg is this much further in than `max_proud` asks
MAX_BLOWS = 20  # seeds 100-149 took 3-12 counted blow steps
CLEAR = 0.05  # m the hammer is lifted after the last blow


@register_solver("HammerPeg", control_modes=TCP_DELTA_MODES)
def solve_hammer_peg(env, seed: int) -> dict:
    """Grasp the handle near the head; aim the head over the peg; strike; repeat until flush; lift clear."""
    with DrivenSolver.episode(env, seed) as s:
        task: HammerPegEnv = env.unwrapped
        n, device = task.num_envs, task.device
        shape = task.HAMMER
        grasp_local = torch.tensor([[shape.head_x - GRASP_FROM_HEAD, 0.0, shape.handle_height / 2 + GRASP_ABOVE]],
                                   device=device).expand(n, 3)
        hammer = task.hammer.pose
        grasp = (hammer * Pose.create_from_pq(grasp_local)).p
        # fingers close across the handle: the TCP's x axis along it
        yaw = DrivenSolver.neutral_yaw(yaw_of(hammer.q), np.pi)
        s.pick("arm", "gripper", grasp, yaw, lift=LIFT)
        q = s.tcp("arm").q

        def tcp_for_face(face: torch.Tensor) -> torch.Tensor:
            """TCP position that puts the striking face's centre at `face`, for the hammer as it sits in the
            grip now (orientation kept)."""
            return face - (task.striking_face() - s.tcp("arm").p)

        # the aim's horizontal lead: the face swings outwards while coming down (the hammer pitches in the grip),
        # so each blow is aimed off the peg by the previous landings' offsets
        lead = torch.zeros(n, 3, device=device)

        def face_target(height: float) -> torch.Tensor:
            target = task.peg_top() + lead
            target[:, 2] += height
            return target

        for _ in range(MAX_BLOWS):
            if bool((task.peg_proud() <= task.max_proud - FLUSH_MARGIN).all()):
                break
            for _ in range(AIM_STEPS):
                s.step({"arm": (tcp_for_face(face_target(RAISE)), q)})
                if bool((torch.linalg.norm(task.striking_face() - face_target(RAISE), dim=1) < AIM_TOL).all()):
                    break
            for _ in range(STRIKE_STEPS):
                s.step({"arm": (tcp_for_face(face_target(-FOLLOW_THROUGH)), q)})
            landing = task.striking_face() - task.peg_top()
            lead[:, :2] = (lead[:, :2] - LEAD_GAIN * landing[:, :2]).clamp(-MAX_LEAD, MAX_LEAD)
        s.move({"arm": (tcp_for_face(face_target(CLEAR)), q)}, max_steps=20, pos_tol=0.01)
        s.hold_until_success()
        return s.info
