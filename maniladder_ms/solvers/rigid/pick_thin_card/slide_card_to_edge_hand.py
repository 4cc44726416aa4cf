"""Scripted solver of SlideCardToEdgeHand (tasks/rigid/pick_thin_card/slide_card_to_edge_hand.py): slide the card
out over the stand's far edge with the index tip, then clamp the overhang between the palm and the index and middle
fingers curled up under it, and lift.

1. Press: the index points down, swung back under the palm (POINT_BACK); it comes down on the card's middle and
   presses PRESS_DEPTH into it.
2. Slide: closed loop on the card, the press point moves along +x until the card's far end is OVERHANG beyond the
   edge; the finger lifts FINGER_LIFT.
3. Clamp: the open hand (thumb raised) lays its palm on the card's end (CLAMP_AHEAD, CLAMP_SIDE); the index and
   middle fingers hook at PIP / DIP in front of the card's end (HOOK_CURL), then swing down and back at their MCP
   joints until their tips press the overhang against the palm (CLAMP).
4. Lift: LIFT_MARGIN beyond `lift_height`.

Why this grasp (and what did not work): docs/tasks/SlideCardToEdgeHand.md.
"""

from __future__ import annotations

import numpy as np
import torch

from maniladder_ms.agents.effectors import leap_fingertip

from maniladder_ms.solvers.control import top_down_quat
from maniladder_ms.geometry import yaw_of
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver
from maniladder_ms.tasks.rigid.pick_thin_card.slide_card_to_edge_hand import SlideCardToEdgeHandEnv
from maniladder_ms.solvers.postures import LEAP_SYNERGIES

POINT_BACK = LEAP_SYNERGIES["point_back"]
TIP_LOW = 0.0042
PRESS_DEPTH = 0.002  # the index tip's target this far below the card's top: it presses the card on the stand
# (1 mm left the tilted tip barely touching where the arm stops 1 mm short of its target)
# 2. slide
TIP_HOVER = 0.02  # m above the card's top where the pointing tip stops before it presses
SLIDE_STEP = 0.01  # m the press point's target leads the finger by at most
SLIDE_STEPS = 60  # control steps the closed-loop slide may take (~0.5 cm a step: the slides measured take 20-40)
FINGER_LIFT = 0.04  # m the hand rises after the slide, clear of the card, before it opens
SLIDE_TOL = 0.002  # m: the slide stops once the card's far end is this near its goal
OVERHANG = 0.045  # the card's far end this far beyond the edge when the slide stops
# 3. clamp: the palm lies on the card's end, the index and middle fingers curl down past the card's end and
# back up under the overhang (tcp frame: x along the fingers, z down; the hand's geometry, open: the palm's
# underside 8.1 cm above the tcp, its front 1.7 cm ahead of it; the fingers' MCP housings, flexed down, reach
# back to 0.7 cm ahead of the tcp)
PALM_ABOVE = 0.081  # the palm's underside this far above the tcp
# the card's end this far ahead of the tcp (under the palm, behind the flexed MCP housings); the clamp tolerates it
# from 1.2 cm behind to 3 cm ahead of the tcp (4.5 cm ahead: 2 of seeds 100-103 lifted)
CLAMP_AHEAD = 0.002
CLAMP_SIDE = 0.007  # the card's centre line this far along the tcp's y axis: under the index and middle fingers
CLAMP_PRESS = 0.002  # the palm's target this far into the card
CLAMP_HOVER = 0.03  # m above the clamp pose where the open hand lines up before it lays its palm on the card
# 4. lift
LIFT_MARGIN = 0.03  # m lifted beyond `lift_height`, so the held card clears the rule's height with room
HOOK_CURL = LEAP_SYNERGIES["hook_curl"]
CLAMP = LEAP_SYNERGIES["clamp"]
OPEN_THUMB_UP = LEAP_SYNERGIES["open_thumb_up"]


@register_solver("SlideCardToEdgeHand", control_modes=TCP_DELTA_MODES)
def solve_slide_card_to_edge_hand(env, seed: int) -> dict:
    """Phases 1-4 of the module docstring."""
    with DrivenSolver.episode(env, seed) as s:
        task: SlideCardToEdgeHandEnv = env.unwrapped
        n, device = task.num_envs, task.device
        yaw = yaw_of(task.card.pose.q)
        q = top_down_quat(yaw, n, device=device)
        axis = torch.stack([torch.cos(yaw), torch.sin(yaw), torch.zeros_like(yaw)], dim=1)
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        # 1. press
        s.set_ee("hand", POINT_BACK, steps=1)
        card_top = task.card.pose.p + up * task.card_thickness / 2
        s.move({"arm": (s.above(card_top, APPROACH_HEIGHT), q)}, max_steps=40)
        tip_offset = leap_fingertip(task.agent) - task.ee.tcp().p - up * TIP_LOW
        s.move({"arm": (s.above(card_top, TIP_HOVER) - tip_offset, q)}, max_steps=30, pos_tol=0.003)
        press = card_top - up * PRESS_DEPTH - tip_offset
        s.move({"arm": (press, q)}, max_steps=15, pos_tol=0.002)
        # 2. slide along +x, closed loop on the card: the press point's target leads the finger by what the card's
        # far end still lacks of the overhang (at most SLIDE_STEP), until it is there
        far_end = lambda: task.card.pose.p + axis * task.card_length / 2  # noqa: E731
        goal = task.far_edge() + OVERHANG
        for _ in range(SLIDE_STEPS):
            lack = goal - far_end()[:, 0]
            if bool((lack <= SLIDE_TOL).all()):
                break
            target = press.clone()
            target[:, 0] = s.tcp("arm").p[:, 0] + lack.clamp(0, SLIDE_STEP)
            s.step({"arm": (target, q)})
        s.move({"arm": (s.above(s.tcp("arm").p, FINGER_LIFT), q)}, max_steps=15, pos_tol=0.005)
        # 3. the clamp: the open hand (thumb raised) comes down with its palm on the card's end; the index and
        # middle fingers hook at their PIP / DIP joints in front of the card's end, then swing down and back at
        # their MCP joints, their tips coming up under the overhang and pressing it against the palm
        s.set_ee("hand", OPEN_THUMB_UP, steps=3)
        side = torch.stack([torch.sin(yaw), -torch.cos(yaw), torch.zeros_like(yaw)], dim=1)  # the tcp's y axis
        top = far_end() + up * task.card_thickness / 2
        clamp = top - axis * CLAMP_AHEAD - side * CLAMP_SIDE - up * (PALM_ABOVE + CLAMP_PRESS)
        s.move({"arm": (s.above(clamp, CLAMP_HOVER), q)}, max_steps=30, pos_tol=0.004)
        s.move({"arm": (clamp, q)}, max_steps=30, pos_tol=0.002)
        s.close_hand("hand", HOOK_CURL, ramp_steps=10, hold_steps=2)
        s.close_hand("hand", CLAMP, ramp_steps=20, hold_steps=5)
        # 4. lift
        s.move({"arm": (s.above(clamp, task.lift_height + LIFT_MARGIN), q)}, max_steps=40)
        s.hold_until_success()
        return s.info
