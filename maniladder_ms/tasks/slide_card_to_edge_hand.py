"""SlideCardToEdgeHand (L2 rigid SX): slide a thin card lying on a low stand over the stand's edge with a
fingertip, then hook the overhang between the curled fingers and the thumb and lift it.

UNFINISHED (not registered: the `@register_task` line is commented out, so nothing imports this module): the
scene, the rule and the slide work; the grasp of the overhang does not yet. Where it stands (seed 0):
- slide: the index fingertip ("point") pressing 1 mm into the card, closed loop on the card's far end, moves
  the card 8 cm without slip to a 4.5 cm overhang (`slid_over_edge` latches); a 3 mm press (8.5 N) made
  the arm lag and an open-loop ramp overshot (the card tipped off).
- hook (`HOOK_THUMB` then `HOOK`, tcp just below the card beyond its end): the thumb sweep stays clear of the
  stand with j13 = 0, but the curling fingers come back at the card's own level and push its end back (the
  fingertip boxes span 5.6 cm in z when curled), and the thumb's dip link brushes the card sideways.
- next to try: the palm on the card (the palm's underside 8.1 cm above the tcp, the card's end just past the
  palm's front, 2.5 cm ahead of the tcp) and the fingers curled down round the card's end and back up under
  it: palm + finger is an `ee.holds` grasp; their PIP joints then lie ~3.5 cm below the card, so the distal
  segments swing up under it rather than into its end.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import leap_fingertip, top_down_quat
from maniladder_ms.envs import register_task  # noqa: F401  (the registration line is commented out)
from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.objects.basket import tilt
from maniladder_ms.objects.tabletop import build_flat_box
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver

from .pick_thin_card import PickThinCardTask

STAND_HALF = (0.12, 0.15)  # the stand's top: 24 cm deep (x), 30 cm wide (y)
STAND_FRICTION = 0.3
FLAT_TILT = np.deg2rad(10)  # the card "lies" on the stand: tilted less than this, its lowest corner on the top
LYING_TOL = 0.004  # m: ... within this of the stand's top


# UNFINISHED, not registered (see the module docstring): @register_task("SlideCardToEdgeHand")
class SlideCardToEdgeHandEnv(PickThinCardTask):
    """**Task:** a thin plastic card lies flat on a low stand (a box on the table), too thin for the fingers to
    get under it there. Press it with a fingertip and slide it over the stand's far edge until it sticks
    out, then take the overhang between the fingers (curled under it) and the thumb (above it), and lift.

    **Randomisation:** the stand (24 x 30 cm, `stand_height` tall) stands with its far edge (the one away
    from the robot) uniform in x in [-0.2, -0.14], its centre's y in [-0.08, 0.08]; the card
    (`card_length` x `card_width` x `card_thickness`, ~14 g) lies on it with its centre within +-4 cm (y) of
    the stand's, its far end 3-7 cm (uniform) short of the far edge, yawed uniform in [-15, 15] degrees.

    **Success:** the card was slid over the edge: at some control step it lay on the stand (tilted by less
    than a fixed small angle, its lowest corner on the stand's top) with a corner at least `min_overhang`
    beyond the far edge (episode memory `slid_over_edge`); and now (the family rule) its lowest point is at
    least `lift_height` above the stand's top and the hand holds it.

    **Level 2:** against Level 1's SX tasks (one grasp of an object standing free, e.g. LiftBottleHand: 2
    stages, power grasp and lift, ~60 steps): a non-prehensile stage first (press and slide a 2 mm card
    7-11 cm, the fingertip's friction against the stand's, without lifting or turning it away), then a
    grasp that exists only because of the slide: the fingers curl under a 4-5 cm overhang whose edge lies
    2 mm thick, between the stand's side and the thumb; 4 stages (press, slide, hook, lift).
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


PRESS_DEPTH = 0.001  # the index tip's target this far below the card's top: it presses the card on the stand
SLIDE_STEP = 0.01  # m the press point's target leads the finger by at most
SLIDE_TOL = 0.002  # m: the slide stops once the card's far end is this near its goal
PRESS_BACK = 0.02  # the press point this far behind the card's centre (along the card, away from the edge)
OVERHANG = 0.045  # the card's far end this far beyond the edge when the slide stops
HOOK_BACK = 0.005  # the tcp this far beyond the card's end (along the card)
HOOK_SIDE = 0.02  # the card's centre line this far along the tcp's y axis: under the thumb, index and middle
HOOK_BELOW = 0.013  # the tcp this far below the card's mid-plane
# the hook's end posture: fingers as "power" but less curled at PIP / DIP (their tips end 4 cm back from where
# they cross the card's plane, short of the stand's side); the thumb swung under the palm with its second joint
# (j13) straight: through its whole sweep it stays above the tcp's level less 1.1 cm (j13 at power's 0.6 dips it
# 2 cm lower halfway), and ends on the card's top, over the index and middle fingers' side
HOOK = np.array([0.0, 1.5, 0.6, 0.2, 0.0, 1.5, 0.6, 0.2, 0.0, 1.5, 0.6, 0.2, 1.6, 0.0, 0.8, 0.8])
HOOK_THUMB = np.concatenate([np.zeros(12), HOOK[12:]])  # the thumb alone, the fingers still open


@register_solver("SlideCardToEdgeHand", control_modes=TCP_DELTA_MODES)
def solve_slide_card_to_edge_hand(env, seed: int) -> dict:
    """Point the index finger down, press it on the card's middle and slide the card out along +x until its
    far end overhangs the edge; lift the finger, hold the hand over the overhang with the fingers pointing
    past its end, close the power grasp (the fingers curl under the overhang, the thumb comes down on it),
    lift."""
    with DrivenSolver.episode(env, seed) as s:
        task: SlideCardToEdgeHandEnv = env.unwrapped
        n, device = task.num_envs, task.device
        yaw = yaw_of(task.card.pose.q)
        q = top_down_quat(yaw, n, device=device)
        axis = torch.stack([torch.cos(yaw), torch.sin(yaw), torch.zeros_like(yaw)], dim=1)
        up = torch.tensor([0.0, 0.0, 1.0], device=device)
        s.set_ee("hand", "point", steps=1)
        card_top = task.card.pose.p + up * task.card_thickness / 2 - axis * PRESS_BACK
        s.move({"arm": (s.above(card_top, APPROACH_HEIGHT), q)}, max_steps=40)
        tip_offset = leap_fingertip(task.agent) - task.ee.tcp().p
        s.move({"arm": (s.above(card_top, 0.02) - tip_offset, q)}, max_steps=30, pos_tol=0.003)
        press = card_top - up * PRESS_DEPTH - tip_offset
        s.move({"arm": (press, q)}, max_steps=15, pos_tol=0.002)
        # slide along +x, closed loop on the card: the press point's target leads the finger by what the card's
        # far end still lacks of the overhang (at most SLIDE_STEP), until it is there
        far_end = lambda: task.card.pose.p + axis * task.card_length / 2  # noqa: E731
        goal = task.far_edge() + OVERHANG
        for _ in range(60):
            lack = goal - far_end()[:, 0]
            if bool((lack <= SLIDE_TOL).all()):
                break
            target = press.clone()
            target[:, 0] = s.tcp("arm").p[:, 0] + lack.clamp(0, SLIDE_STEP)
            s.step({"arm": (target, q)})
        s.move({"arm": (s.above(s.tcp("arm").p, 0.04), q)}, max_steps=15, pos_tol=0.005)
        # the hook: the open hand over the overhang, its fingers pointing past the card's end, the card under
        # the middle and ring fingers, the tcp just below the card; the thumb swings over the card first,
        # then the fingers curl down past its end and back up under it, pressing it against the thumb
        s.set_ee("hand", "open", steps=3)
        side = torch.stack([torch.sin(yaw), -torch.cos(yaw), torch.zeros_like(yaw)], dim=1)  # the tcp's y axis
        hook = far_end() + axis * HOOK_BACK - side * HOOK_SIDE - up * HOOK_BELOW
        s.move({"arm": (s.above(hook, 0.06), q)}, max_steps=30, pos_tol=0.004)
        s.move({"arm": (hook, q)}, max_steps=30, pos_tol=0.002)
        s.close_hand("hand", HOOK_THUMB, ramp_steps=20, hold_steps=2)
        s.close_hand("hand", HOOK, ramp_steps=30, hold_steps=8)
        s.move({"arm": (s.above(hook, task.lift_height + 0.04), q)}, max_steps=40)
        s.hold_until_success()
        return s.info
