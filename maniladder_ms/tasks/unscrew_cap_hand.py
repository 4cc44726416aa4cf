"""UnscrewCapHand (L2 rigid SX, family UnscrewCap): one LEAP hand unscrews the cap of a bottle clamped to the table."""

from __future__ import annotations

import torch

from maniladder_ms.envs import register_task
from maniladder_ms.objects.jar import JarShape
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.twist import is_wound_up, unscrew, wind_up_target

from .unscrew_cap import UnscrewCapTask


@register_task("UnscrewCapHand")
class UnscrewCapHandEnv(UnscrewCapTask):
    """**Task:** TODO

    **Success:** TODO `release_angle` `thread_torque`
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    CLAMPED = True
    JAR_REGION = (-0.18, -0.1, -0.08, 0.08)
    TASK_REGION = (-0.25, -0.03, -0.15, 0.15)
    jar_shape = JarShape(body_radius=0.04, body_height=0.11, neck_radius=0.022, neck_height=0.03,
                         lid_radius=0.03, lid_height=0.03)
    body_color, lid_color = (0.3, 0.6, 0.4, 1), (0.95, 0.75, 0.1, 1)


# the power grasp closes on the cap with the TCP on its axis this far (TCP frame, z down) from the cap's
# mid-height: 1 cm lower, so the curled fingertips reach under the cap's rim onto the neck
GRIP_OFFSET = (0.0, 0.0, -0.01)
RAMP_STEPS = 20  # control steps the pinch closes over (the clamped cap cannot be pushed away)
FOLLOW = 0.7  # the cap turns by ~0.8 of the wrist's turn in the power grasp (the fingers slip): measured
CLEARANCE = 0.1  # m above the cap top where the hand winds its wrist up (it rises from the rest pose first)


@register_solver("UnscrewCapHand", control_modes=TCP_DELTA_MODES)
def solve_unscrew_cap_hand(env, seed: int) -> dict:
    """Rise, go above the cap winding the wrist up, then twist strokes with the index-thumb pinch
    (`solvers.twist.unscrew`) until the cap is off."""
    with DrivenSolver.episode(env, seed) as s:
        task: UnscrewCapHandEnv = env.unwrapped
        device = task.device

        def high():  # above the cap; from the rest pose (below the cap top) straight up first
            target = task.lid_top() + torch.tensor([0.0, 0.0, CLEARANCE], device=device)
            tcp = s.tcp("arm").p
            rise = tcp[:, 2] < target[:, 2] - 0.02
            return torch.where(rise[:, None], torch.cat([tcp[:, :2], target[:, 2:]], dim=1), target)

        for _ in range(80):
            errs = s.step({"arm": wind_up_target(s, "arm", high(), GRIP_OFFSET)})
            ep, _ = errs["arm"]
            if bool((ep < 0.01).all()) and is_wound_up(s, "arm"):
                break
        unscrew(s, task, "arm", "hand", offset=GRIP_OFFSET, synergy="power", ramp_steps=RAMP_STEPS,
                preshape="preshape", follow=FOLLOW)
        s.hold_until_success()
        return s.info
