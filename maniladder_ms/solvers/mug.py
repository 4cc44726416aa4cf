"""LEAP solver phases with a mug (`objects.mug`): a top-down power grasp on a standing mug's body carried to a coaster
(PlaceMugOnCoasterHand's solver; HandoverMugHands' regrasp after the pass) and a closed-loop set-down."""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import uprighting
from maniladder_ms.objects.mug import COASTER_HEIGHT

from .bimanual import glide
from .driven import DrivenSolver

# the power grasp closes with the TCP this far (TCP frame, yaw 0: x towards the fingertips, y along the finger row
# towards the ring finger) from the mug's axis: the thumb, swung under the palm ~5 cm behind the TCP, clears the
# near side of the 8.4 cm mug on the way down (with the TCP on the axis it knocked the mug over on 2 of 15
# seeds), and the finger row's middle (the middle finger, 1.5 cm towards the ring finger) is over the axis
GRASP_OFFSET = (-0.015, -0.015, 0.0)
# the handle lies along the finger row (HANDLE_AT: to the ring finger's side, or the index finger's, period pi:
# whichever keeps the wrist nearer its rest yaw); under the fingertips or the thumb 5 and 6 of 9 seeds failed
HANDLE_AT, HANDLE_PERIOD = np.pi / 2, np.pi
# m: the TCP above the mug's bottom when the hand closes (4.3 cm below the rim); seeds 112-123 at 5.5 cm (3.5 cm
# below the rim) / 4.7 / 4 cm: 9 / 12 / 8 of 12 (the mug slides down out of the fingers in the carry, or the
# set-down leaves it more than 2 cm off centre)
GRASP_HEIGHT = 0.047
CARRY_HEIGHT = 0.08  # m the TCP rises after the grasp before the carry (the mug's bottom clears the table by ~8 cm)
CARRY_STEP = 0.01  # m a control step along the lift and the carry (faster swings the mug in the grip)
STRAIGHTEN_ABOVE = 0.02  # m: the mug's bottom this far over the coaster when its tilt in the grip is taken out
LOWER_STEP = 0.003  # m a control step of the closed-loop set-down
SET_DOWN_GAP = 0.002  # m: the set-down stops with the mug's bottom this close to the coaster's top
RELEASE_STEPS = 20  # control steps over which the fingers, then the thumb, open
LOWER_SLACK = 10  # control steps the set-down may take beyond its planned STRAIGHTEN_ABOVE / LOWER_STEP
RETREAT_HEIGHT = 0.08  # m the open hand rises off the placed mug (clear of its rim and handle)
# measured on PlaceMugOnCoasterHand, the mug's yaw in [225, 315]: seeds 100-149 45/50 (117, 130, 131, 147, 148
# fail), held out 150-199 48/50 (163, 179). What fails (seen on the demo seeds as first built, yaw over 360 deg): the
# mug slips down out of the fingers in the carry (a grasp with the handle on the index finger's side, wrist yaw near
# -pi/2, slips most); relaxing and opening the fingers tilts the standing mug 5-10 degrees and it lands 2-2.5 cm off
# centre (seed 18); the rising open hand catches the mug and drags it off the coaster (seed 16)


def _straighten(s: DrivenSolver, task, arm: str, max_steps: int = 30) -> torch.Tensor:
    """Turn the TCP (about itself) by the mug's tilt in the grip; returns the new orientation."""
    q = uprighting(task.mug.pose.q, s.tcp(arm).q)
    s.move({arm: (s.tcp(arm).p.clone(), q)}, max_steps=max_steps)
    return q


def lower_mug(s: DrivenSolver, task, arm: str, tcp_for, floor: torch.Tensor, q: torch.Tensor, above: float):
    """Lower the held mug closed loop from `above` its floor (heights `floor`): each step the target is where the TCP
    must be for the mug (as it hangs in the grip now), `tcp_for(gap)`, until the mug's bottom is down (following it
    further drags the standing mug off centre)."""
    for k in range(int(above / LOWER_STEP) + LOWER_SLACK):
        if bool((task.mug.pose.p[:, 2] - floor < SET_DOWN_GAP).all()):
            break
        s.step({arm: (tcp_for(max(above - (k + 1) * LOWER_STEP, 0.0)), q)})


def mug_to_coaster(s: DrivenSolver, task, arm: str = "arm", ee: str = "hand") -> torch.Tensor:
    """Pick the mug `task.mug` standing upright on the table with the LEAP hand `ee` on `arm`, set it on the coaster
    `task.coaster` and let go (PlaceMugOnCoasterHand's solver; HandoverMugHands' regrasp after the pass); returns
    the hand's last orientation."""
    dev, n = task.device, task.num_envs
    handle = quaternion_apply(task.mug.pose.q, torch.tensor([[-1.0, 0.0, 0.0]], device=dev).expand(n, 3))
    yaw = DrivenSolver.neutral_yaw(torch.atan2(handle[:, 1], handle[:, 0]) - HANDLE_AT, HANDLE_PERIOD)
    q = top_down_quat(yaw, n, device=dev)
    grasp = task.mug.pose.p + torch.tensor([0.0, 0.0, GRASP_HEIGHT], device=dev)
    grasp = grasp + quaternion_apply(q, torch.tensor([GRASP_OFFSET], device=dev).expand(n, 3))
    s.pick(arm, ee, grasp, yaw, lift=0)
    glide(s, {arm: (grasp, s.above(grasp, CARRY_HEIGHT), q)}, step_length=CARRY_STEP, settle_steps=5)
    q = _straighten(s, task, arm)

    def place_tcp(gap: float) -> torch.Tensor:  # the TCP that puts the mug's bottom centre `gap` over the coaster
        return task.coaster.pose.p + s.tcp(arm).p - task.mug.pose.p + torch.tensor(
            [0.0, 0.0, COASTER_HEIGHT + gap], device=dev)

    start = s.tcp(arm).p.clone()
    across = place_tcp(0.0)
    across[:, 2] = start[:, 2]
    glide(s, {arm: (start, across, q)}, step_length=CARRY_STEP, settle_steps=5)
    glide(s, {arm: (across, place_tcp(STRAIGHTEN_ABOVE), q)}, step_length=CARRY_STEP, settle_steps=10)
    q = _straighten(s, task, arm)
    lower_mug(s, task, arm, place_tcp, task.coaster.pose.p[:, 2] + COASTER_HEIGHT, q, STRAIGHTEN_ABOVE)
    s.move({arm: (s.tcp(arm).p.clone(), q)}, max_steps=3)  # hold there
    # let go: joint targets to where the joints are (no squeeze), then the fingers open, then the thumb
    hand = task.agent.controller.controllers[ee].qpos.clone()
    s.close_hand(ee, hand, ramp_steps=5, hold_steps=2)
    hand[:, :12] = 0
    s.close_hand(ee, hand, ramp_steps=RELEASE_STEPS, hold_steps=2)
    s.close_hand(ee, "open", ramp_steps=RELEASE_STEPS, hold_steps=2)
    s.move({arm: (s.above(s.tcp(arm).p.clone(), RETREAT_HEIGHT), q)}, max_steps=30, pos_tol=0.02)
    return q
