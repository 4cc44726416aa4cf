"""SlideCardToEdgeHand (L2 rigid SX): slide a thin card lying on a low stand over the stand's edge with a
fingertip, then clamp the overhang between the palm (on the card) and the index and middle fingers curled
round the card's end and back up under it, and lift it.

How the grasp came about (the earlier tries, for whoever changes it): the fingers of a "power" grasp with the
tcp just below the card, beyond its end, come back at the card's own level and push its end back (the curled
fingertip boxes span 5.6 cm in z), and the thumb's swing brushes the card sideways; what works is the palm
on the card (the card's end under the palm, 2 mm ahead of the tcp) and the fingers hooked first at
PIP / DIP in front of the card's end (the hook's lowest point stays 5 cm above the tcp, which lies ~1 mm
above the table) and then swung down and back at the MCP joints, so their tips rise under the overhang.
The clamp tolerates the card's end from 1.2 cm behind to 3 cm ahead of the tcp (`CLAMP_AHEAD`, seeds 100-103
all lifted; 4.5 cm ahead: 2 of 4).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import leap_fingertip, top_down_quat
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import tilt, yaw_of, yaw_quat
from maniladder_ms.objects.tabletop import build_flat_box
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver

from .base import PickThinCardTask

STAND_HALF = (0.12, 0.15)  # the stand's top: 24 cm deep (x), 30 cm wide (y)
STAND_FRICTION = 0.3
FLAT_TILT = np.deg2rad(10)  # the card "lies" on the stand: tilted less than this, its lowest corner on the top
LYING_TOL = 0.004  # m: ... within this of the stand's top


@register_task("SlideCardToEdgeHand")
class SlideCardToEdgeHandEnv(PickThinCardTask):
    """**Task:** a thin plastic card lies flat on a low stand (a box on the table), too thin for the fingers to
    get under it there. Press it with a fingertip and slide it over the stand's far edge until it sticks
    out, then take the overhang in the hand (fingers curled up under it, the palm on it), and lift.

    **Randomisation:** the stand (24 x 30 cm, `stand_height` tall) stands with its far edge (the one away
    from the robot) uniform in x in [-0.2, -0.14], its centre's y in [-0.08, 0.08]; the card
    (`card_length` x `card_width` x `card_thickness`, ~14 g) lies on it with its centre within +-4 cm (y) of
    the stand's, its far end 3-7 cm (uniform) short of the far edge, yawed uniform in [-15, 15] degrees.

    **Success:** the card was slid over the edge: at some control step it lay on the stand (tilted by less
    than a fixed small angle, its lowest corner on the stand's top) with a corner at least `min_overhang`
    beyond the far edge (episode memory `slid_over_edge`); and now (the family rule) its lowest point is at
    least `lift_height` above the stand's top and the hand holds it.

    **Level 2:** against Level 1's SX tasks (one grasp of an object standing free, e.g. LiftBottleHand: 2
    stages, power grasp and lift, ~80 steps): a non-prehensile stage first (press a 2 mm card with one
    fingertip, 2 mm into it, and slide it 7-11 cm by the fingertip's friction against the stand's, without
    lifting or turning it away, to a 3-5 cm overhang), then a grasp that exists only because of the slide and
    that no synergy closes: the palm laid on the card's end with the thumb raised out of the way, the index
    and middle fingers hooked in front of the card's end and only then swung down and back round its 2 mm
    edge and up under the overhang; 4 stages (press, slide, clamp, lift), ~120 steps.
    """

    max_dense_reward = 6
    TASK_REGION = (-0.45, -0.05, -0.25, 0.25)
    PARAMS = PickThinCardTask.PARAMS + ("stand_height", "min_overhang")

    @property
    def surface_height(self) -> float:
        return self.stand_height

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.stand = build_flat_box(self.scene, "stand", (*STAND_HALF, self.stand_height / 2),
                                    color=(0.35, 0.35, 0.38, 1), friction=STAND_FRICTION, kinematic=True)
        self.memory.flag("slid_over_edge")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            edge = -0.2 + torch.rand(b) * 0.06
            stand_y = (torch.rand(b) * 2 - 1) * 0.08
            stand = torch.stack([edge - STAND_HALF[0], stand_y, torch.full((b,), self.stand_height / 2)], dim=1)
            self.stand.set_pose(Pose.create_from_pq(stand))
            gap = 0.03 + torch.rand(b) * 0.04
            card = torch.stack([edge - gap - self.card_length / 2, stand_y + (torch.rand(b) * 2 - 1) * 0.04,
                                torch.full((b,), self.stand_height + self.card_thickness / 2)], dim=1)
            self.card.set_pose(Pose.create_from_pq(card, yaw_quat((torch.rand(b) * 2 - 1) * np.deg2rad(15))))

    def far_edge(self) -> torch.Tensor:
        """(b,) x of the stand's far edge."""
        return self.stand.pose.p[:, 0] + STAND_HALF[0]

    def overhang(self) -> torch.Tensor:
        """(b,) how far (m) the card's farthest corner reaches beyond the stand's far edge (negative: short of it)."""
        return self.card_corners()[..., 0].max(dim=1).values - self.far_edge()

    def lies_on_stand(self) -> torch.Tensor:
        return (self.card_height().abs() <= LYING_TOL) & (tilt(self.card) < FLAT_TILT)

    def _update_memory(self):
        self.memory.latch("slid_over_edge", (self.overhang() >= self.min_overhang) & self.lies_on_stand())

    def task_conditions(self, info: dict) -> torch.Tensor:
        info["slid_over_edge"] = self.memory["slid_over_edge"]
        info["overhang"] = self.overhang()
        return info["slid_over_edge"]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"],
                   slid_over_edge=info["slid_over_edge"])
        if "state" in self.obs_mode:
            obs.update(card_pose=self.card.pose.raw_pose, stand_pos=self.stand.pose.p, overhang=info["overhang"],
                       tcp_to_card=self.card.pose.p - self.ee.tcp().p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # fingertip to the card, the card slid out to the overhang, then held and lifted
        reach = torch.linalg.norm(self.card.pose.p - leap_fingertip(self.agent), dim=1)
        reward = 1 - torch.tanh(5 * reach)
        slid = info["slid_over_edge"].float()
        reward += torch.where(info["slid_over_edge"], torch.ones_like(reach),
                              (info["overhang"] / self.min_overhang).clamp(0, 1))
        reward += slid * (info["is_grasped"].float() + 2 * (info["height"] / self.lift_height).clamp(0, 1)
                          * info["is_grasped"])
        reward[info["success"]] = self.max_dense_reward
        return reward


# the press posture: "point" with the index swung back past straight down (MCP 2.0 rad): its tip ends 4.1 cm
# behind the tcp instead of 1.7 cm ahead, and it presses the card's centre (was 2 cm behind it): the tcp stays
# 7.8 cm further from the robot's base (with "point" 2 cm behind the centre, the top-down hand could not get
# low enough over cards starting nearest the robot, their centres ~30 cm ahead of the base: 5 of seeds 100-149
# failed; with the press at the centre the slide ends with the tip 1.5 cm short of the edge); the tilted
# tip's lowest corner lies `TIP_LOW` below the centre of its end face (the tip's collision box, measured)
POINT_BACK = np.array([0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 0.0, 0.0])
TIP_LOW = 0.0042
PRESS_DEPTH = 0.002  # the index tip's target this far below the card's top: it presses the card on the stand
# (1 mm left the tilted tip barely touching where the arm stops 1 mm short of its target)
TIP_HOVER = 0.02  # m above the card's top where the pointing tip stops before it presses
SLIDE_STEP = 0.01  # m the press point's target leads the finger by at most
SLIDE_STEPS = 60  # control steps the closed-loop slide may take (~0.5 cm a step: the slides measured take 20-40)
FINGER_LIFT = 0.04  # m the hand rises after the slide, clear of the card, before it opens
SLIDE_TOL = 0.002  # m: the slide stops once the card's far end is this near its goal
OVERHANG = 0.045  # the card's far end this far beyond the edge when the slide stops
# the clamp: the palm lies on the card's end, the index and middle fingers curl down past the card's end and
# back up under the overhang (tcp frame: x along the fingers, z down; the hand's geometry, open: the palm's
# underside 8.1 cm above the tcp, its front 1.7 cm ahead of it; the fingers' MCP housings, flexed down, reach
# back to 0.7 cm ahead of the tcp)
PALM_ABOVE = 0.081  # the palm's underside this far above the tcp
CLAMP_AHEAD = 0.002  # the card's end this far ahead of the tcp (under the palm, behind the flexed MCP housings)
CLAMP_SIDE = 0.007  # the card's centre line this far along the tcp's y axis: under the index and middle fingers
CLAMP_PRESS = 0.002  # the palm's target this far into the card
CLAMP_HOVER = 0.03  # m above the clamp pose where the open hand lines up before it lays its palm on the card
LIFT_MARGIN = 0.03  # m lifted beyond `lift_height`, so the held card clears the rule's height with room
# the thumb raised (j12 near its lower limit, -0.349): open, its links reach 4 mm below the palm's underside, over
# the stand, and would hold the palm off the card; the ring finger (beside the card) stays straight
THUMB_UP = [-0.34, 0.0, 0.0, 0.0]
HOOK_CURL = np.array([0.0, 0.0, 1.57, 1.57, 0.0, 0.0, 1.57, 1.57, 0.0, 0.0, 0.0, 0.0, *THUMB_UP])  # hooks at the front
CLAMP = np.array([0.0, 1.57, 1.57, 1.57, 0.0, 1.57, 1.57, 1.57, 0.0, 0.0, 0.0, 0.0, *THUMB_UP])  # swung under
OPEN_THUMB_UP = np.array([0.0] * 12 + THUMB_UP)


@register_solver("SlideCardToEdgeHand", control_modes=TCP_DELTA_MODES)
def solve_slide_card_to_edge_hand(env, seed: int) -> dict:
    """Point the index finger down (swung back under the palm), press it on the card's middle and slide the card out along +x until its
    far end overhangs the edge; lift the finger; lay the open hand (thumb raised) with its palm on the card's
    end, the index and middle fingers over the overhang; hook them at PIP / DIP in front of the card's end,
    then swing them down and back at the MCP joints until their tips press the overhang against the palm;
    lift."""
    with DrivenSolver.episode(env, seed) as s:
        task: SlideCardToEdgeHandEnv = env.unwrapped
        n, device = task.num_envs, task.device
        yaw = yaw_of(task.card.pose.q)
        q = top_down_quat(yaw, n, device=device)
        axis = torch.stack([torch.cos(yaw), torch.sin(yaw), torch.zeros_like(yaw)], dim=1)
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        s.set_ee("hand", POINT_BACK, steps=1)
        card_top = task.card.pose.p + up * task.card_thickness / 2
        s.move({"arm": (s.above(card_top, APPROACH_HEIGHT), q)}, max_steps=40)
        tip_offset = leap_fingertip(task.agent) - task.ee.tcp().p - up * TIP_LOW
        s.move({"arm": (s.above(card_top, TIP_HOVER) - tip_offset, q)}, max_steps=30, pos_tol=0.003)
        press = card_top - up * PRESS_DEPTH - tip_offset
        s.move({"arm": (press, q)}, max_steps=15, pos_tol=0.002)
        # slide along +x, closed loop on the card: the press point's target leads the finger by what the card's
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
        # the clamp: the open hand (thumb raised) comes down with its palm on the card's end; the index and
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
        s.move({"arm": (s.above(clamp, task.lift_height + LIFT_MARGIN), q)}, max_steps=40)
        s.hold_until_success()
        return s.info
