"""ThreadRopeThroughRingHands (L2 deformable DX): one LEAP hand feeds a rope end through a standing ring, the other
takes it on the far side and pulls it through."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.objects.tabletop import build_standing_ring
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import glide
from maniladder_ms.solvers.driven import APPROACH_HEIGHT, DrivenSolver, SCISSOR_RAMP_STEPS
from maniladder_ms.tasks.rope.base import RopeTask

RING_COLOR = (0.3, 0.32, 0.38, 1)
RING_TUBE = 0.006  # radius of the ring's tube (m)
RING_HEIGHT = 0.06  # the ring's centre above the table: its inner bottom 2.5 cm up, under the rope's feed height
FEED_SIDE = -1.0  # the rope lies on this side (sign of y) of the ring: the right hand feeds, the left pulls


@register_task("ThreadRopeThroughRingHands")
class ThreadRopeThroughRingHandsEnv(RopeTask, ManiLadderEnv):
    """**Task:** a ring stands upright on a post fixed to the table, its axis across the table (along y); a rope
    lies on the table on the right arm's side of it, its end pointing at the ring. Thread the rope's end through
    the ring and pull it out on the other side, then let go: one hand feeds the end through, the other takes
    it beyond the ring and pulls.

    **Randomisation:** the ring (inner radius `ring_radius`, its centre 6 cm above the table) stands at x
    uniform in [-0.12, -0.06], y uniform in [-0.03, 0.03]; the rope (40 cm, 20 capsules of 1.6 cm
    diameter, stiffer than the default rope: a cord) lies flat in a gentle S (in-plane turns amp * sin(2 pi
    (k + 1) / 20 + phase), amp uniform in [0, 0.05] rad, phase uniform) on the right (-y) side of the ring: its
    first tip 4-7 cm (uniform) from the ring's plane and within +-1.5 cm (uniform) of the ring's centre along x,
    from there it runs away from the ring, its first capsule heading within +-10 degrees (uniform) of -y.

    **Success:** the rope passes through the ring's disc exactly once (`rope.through_ring` with the ring's inner
    radius `ring_radius`) with at least `min_side` of its length on each side of the crossing; the rope was
    pulled through (`pulled_through`, episode memory: at some step a hand held (`ee.holds`) a capsule lying
    at least `min_side` beyond the ring's plane on the far side (the side away from where the rope started)
    while the rope passed through the ring), so a push alone or a dropped rope does not count; and no hand
    touches the rope (`ee.touches`): it stays threaded by itself.

    **Level 2:** (against Level 1's StretchRopeHands: 2 stages, both hands pinch and lift, horizon 150, T ~ 20):
    6 stages across both arms (pinch, lift and feed, lay on the ring and let go, pinch on the far side, pull
    through, lay down and let go) around a fixed obstacle: the right hand pinches the rope 11 cm from its end,
    lifts it to 2 cm above the centre of a ring 7 cm across and feeds the end along the ring's axis, its
    fingertips stopping ~1.5 cm short of the 1.2 cm tube so that ~8 cm of cord stick out beyond it; the LEAP
    hands (palms ~13 cm long, the curled ring finger reaching 8 cm ahead of the pinch) cannot both hold the rope
    within a few cm of the ring, so the feeder lays the rope on the ring's bottom and lets go and the left hand
    takes the protruding end where it came to rest, its fingers 1-3 cm from the ring, then pulls ~12 cm through;
    a fed end that misses the ring's opening, slips back out or is pushed but not pulled fails.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.3, 0.1, -0.52, 0.32)  # the rope lies up to 51 cm right (-y) of the ring
    PARAMS = ("ring_radius", "min_side")
    # a cord 40 times stiffer in bending than the default rope: the end the feeding hand holds out (5 capsules
    # beyond the pinch) must stay roughly straight to enter the ring (the default rope's end hangs straight down;
    # at 10x it drooped 4.5 cm over 8 cm and poked only 1.5 cm through, seed 100)
    rope_config = rope.RopeConfig(bend_stiffness=0.08, bend_damping=0.016)

    def _load_scene(self, options: dict):
        super()._load_scene(options)  # the rope (RopeTask)
        self.ring = build_standing_ring(self.scene, "ring", self.ring_radius, RING_TUBE, RING_HEIGHT, RING_COLOR)
        self.memory.flag("pulled_through")
        self.memory.value("start_side", 1)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            ring = torch.stack([torch.rand(b) * 0.06 - 0.12, torch.rand(b) * 0.06 - 0.03, torch.zeros(b)], dim=1)
            self.ring.set_pose(Pose.create_from_pq(ring))
            heading = FEED_SIDE * np.pi / 2 + (torch.rand(b) * 2 - 1) * np.deg2rad(10)
            gap = 0.04 + torch.rand(b) * 0.03
            tip = torch.stack([ring[:, 0] + (torch.rand(b) * 2 - 1) * 0.015, ring[:, 1] + FEED_SIDE * gap], dim=1)
            turns = rope.wavy_turns(b, self.rope_config.segments, 0.05)
            self.rope.lay_flat(tip, heading, turns, from_tip=True)
            self.memory.store("start_side", torch.full((b, 1), FEED_SIDE), env_idx)

    def ring_frame(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The ring's centre and unit axis, [B, 3] each."""
        pose = self.ring.pose
        centre = pose.p + torch.tensor([0.0, 0.0, RING_HEIGHT], device=self.device)
        axis = torch.tensor([0.0, 1.0, 0.0], device=self.device).expand_as(centre)
        return centre, axis

    def _threading(self):
        points = self.rope.points()
        centre, axis = self.ring_frame()
        count, shorter = rope.through_ring(points, centre, axis, self.ring_radius)
        # how far beyond the ring's plane, on the far side, each capsule lies [B, segments]
        beyond = -((points[:, 1:-1] - centre[:, None]) * axis[:, None]).sum(-1) * self.memory["start_side"]
        return count, shorter, beyond

    def _far_hold(self, beyond: torch.Tensor) -> torch.Tensor:
        """(B,) bool: a hand holds a capsule lying at least `min_side` beyond the ring on the far side."""
        held = torch.zeros(beyond.shape[0], dtype=torch.bool, device=self.device)
        for i, link in enumerate(self.rope.links):
            far = beyond[:, i] >= self.min_side
            if far.any():
                held |= far & self.ee.holds(link)
        return held

    def _update_memory(self):
        count, _, beyond = self._threading()
        self.memory.latch("pulled_through", (count == 1) & self._far_hold(beyond))

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in ("left", "right")}
        obs.update(pulled_through=info["pulled_through"])
        if "state" in self.obs_mode:
            centre, axis = self.ring_frame()
            obs.update(rope_points=self.rope.points().flatten(1), ring_centre=centre, ring_axis=axis)
        return obs

    def evaluate(self):
        count, shorter, _ = self._threading()
        info = dict(crossings=count, shorter_side=shorter, threaded=(count == 1) & (shorter >= self.min_side),
                    pulled_through=self.memory["pulled_through"], touching_rope=self.ee.touches(self.rope.links))
        info["success"] = info["threaded"] & info["pulled_through"] & ~info["touching_rope"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        end = self.rope.links[0].pose.p
        centre, _ = self.ring_frame()
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.rope.links[FEED_CAPSULE].pose.p - self.ee.tcp("right").p, dim=1))
        to_ring = 1 - torch.tanh(5 * torch.linalg.norm(end - centre, dim=1))
        through = (info["crossings"] == 1).float() * (1 + (info["shorter_side"] / self.min_side).clamp(0, 1))
        reward = reach + to_ring + through + info["pulled_through"].float()
        reward = reward + (info["threaded"] & info["pulled_through"] & ~info["touching_rope"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward


FEED_CAPSULE = 5  # the feeding hand pinches this capsule (0: the end one): 5 capsules (10 cm) stick out beyond it
TAKE_CAPSULE = 1  # the pulling hand pinches this one beyond the ring
FEED_LIFT = 0.02  # the pinched capsule is fed this far above the ring's centre (the end droops a little)
FEED_STOP = 0.027  # the feeding pinch stops this far short of the ring's plane (fingertips ~1.5 cm from the tube)
REST_Z = 0.045  # the feeding hand lays the rope on the ring's bottom tube from this height, then lets go
PULL = 0.12  # the pulling hand draws the rope this far away from the ring
STEP = 0.006  # metres a control step while the rope is held (faster swings it out of the pinch)


@register_solver("ThreadRopeThroughRingHands", control_modes=TCP_DELTA_MODES)
def solve_thread_rope_through_ring_hands(env, seed: int) -> dict:
    """The right hand takes the rope `FEED_CAPSULE` capsules from its end in the "scissor" pinch (fingers along
    the rope, facing the ring), lifts it above the ring's centre and feeds the end through, lays the rope on the
    ring's bottom and lets go (the two big hands cannot both reach the rope within a few cm of the ring); the
    left hand, waiting above the far side, pinches the protruding end and pulls the rope `PULL` away from the
    ring, lowers it to the table, lets go and rises."""
    with DrivenSolver.episode(env, seed) as s:
        task: ThreadRopeThroughRingHandsEnv = env.unwrapped
        device = task.device
        centre, axis = task.ring_frame()
        toward = -FEED_SIDE  # the feed moves along +y * toward
        feed_yaw = torch.full((centre.shape[0],), toward * np.pi / 2, device=device)
        link = task.rope.links[FEED_CAPSULE]
        grip = link.pose.p.clone()
        grip[:, 2] = task.rope_config.radius
        p, q = DrivenSolver.scissor_pose(grip, rope.segment_yaw(link.pose.q), around=toward * np.pi / 2)
        s.set_ee("right_hand", "scissor_open", steps=0)
        s.set_ee("left_hand", "scissor_open", steps=0)
        # the left hand waits high above the far side, facing the ring
        wait = centre.clone()
        wait[:, 1] += toward * 0.1  # clear of the feeding hand's fingers
        wait[:, 2] = 0.16
        lp, lq = DrivenSolver.scissor_pose(wait, -feed_yaw, mirror=True, around=-toward * np.pi / 2)
        s.arm_targets["left_arm"] = (lp, lq)
        s.move({"right_arm": (s.above(p, APPROACH_HEIGHT), q)}, max_steps=60)
        s.move({"right_arm": (p, q)}, max_steps=40, pos_tol=0.003)
        s.close_hand("right_hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        # lift the pinched capsule to the feed height, line it up with the ring's axis, turn along it
        start = centre.clone()
        start[:, 1] += -toward * (FEED_STOP + 0.04)
        start[:, 2] += FEED_LIFT
        fp, fq = DrivenSolver.scissor_pose(start, feed_yaw, around=toward * np.pi / 2)
        up = p.clone()
        up[:, 2] = fp[:, 2]
        glide(s, {"right_arm": (p, up, q)}, step_length=STEP, settle_steps=3)
        glide(s, {"right_arm": (up, fp, fq)}, step_length=STEP, settle_steps=8)
        stop = start.clone()
        stop[:, 1] = centre[:, 1] - toward * FEED_STOP
        sp, _ = DrivenSolver.scissor_pose(stop, feed_yaw, around=toward * np.pi / 2)
        glide(s, {"right_arm": (fp, sp, fq)}, step_length=STEP, settle_steps=8)
        # lay the rope on the ring's bottom and let go; the right hand backs off upwards
        rest = stop.clone()
        rest[:, 2] = REST_Z
        rp, _ = DrivenSolver.scissor_pose(rest, feed_yaw, around=toward * np.pi / 2)
        glide(s, {"right_arm": (sp, rp, fq)}, step_length=STEP, settle_steps=3)
        s.set_ee("right_hand", "scissor_open", steps=6)
        back = rp.clone()
        back[:, 1] -= toward * 0.04
        back[:, 2] += 0.12
        s.arm_targets["right_arm"] = (back, fq)
        # the left hand pinches the protruding end where it lies
        end = task.rope.links[TAKE_CAPSULE]
        tp, tq = DrivenSolver.scissor_pose(end.pose.p.clone(), rope.segment_yaw(end.pose.q), mirror=True,
                                           around=-toward * np.pi / 2)
        s.move({"left_arm": (s.above(tp, 0.05), tq)}, max_steps=30, pos_tol=0.01)
        s.move({"left_arm": (tp, tq)}, max_steps=30, pos_tol=0.003)
        s.close_hand("left_hand", "scissor", ramp_steps=SCISSOR_RAMP_STEPS)
        pull = tp.clone()
        pull[:, 1] += toward * PULL
        pull[:, 2] = torch.maximum(tp[:, 2], centre[:, 2] + 0.036 - 0.01)
        glide(s, {"left_arm": (tp, pull, tq)}, step_length=STEP, settle_steps=3)
        down = pull.clone()
        down[:, 2] = task.rope_config.radius + 0.036 + 0.004
        glide(s, {"left_arm": (pull, down, tq)}, step_length=STEP, settle_steps=3)
        s.set_ee("left_hand", "scissor_open", steps=6)
        s.move({"left_arm": (s.above(down, 0.08), tq)}, max_steps=15, pos_tol=0.02)
        s.hold_until_success()
        return s.info
