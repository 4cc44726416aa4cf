"""HandoverBallHands (L1 rigid DX, family Handover): pass a tennis ball from the left LEAP hand to the right one."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_to_matrix
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.helpers import LEAP_SYNERGIES, top_down_quat
from maniladder_ms.envs import register_task
from maniladder_ms.objects.tabletop import place_at_rest
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import HandoverSolver, glide, roll_targets

from .base import HandoverTask

BALL_RADIUS = 0.0335  # a tennis ball: 6.7 cm across, 58 g
BALL_MASS = 0.058
BALL_FRICTION = 0.8  # felt
# the stand: a ring of small boxes the ball sits in, so that it does not roll away before the pick
STAND_RING_RADIUS = 0.02  # to the boxes' centres
STAND_HEIGHT = 0.015
STAND_SEGMENTS = 12


def build_ball(scene, name: str, color=(0.8, 0.95, 0.2, 1)):
    """A tennis ball: a sphere of `BALL_RADIUS`, `BALL_MASS`, felt friction."""
    builder = scene.create_actor_builder()
    volume = 4 / 3 * np.pi * BALL_RADIUS ** 3
    material = physx.PhysxMaterial(BALL_FRICTION, BALL_FRICTION, 0.0)
    builder.add_sphere_collision(radius=BALL_RADIUS, material=material, density=BALL_MASS / volume)
    builder.add_sphere_visual(radius=BALL_RADIUS, material=sapien.render.RenderMaterial(base_color=list(color), roughness=0.9))
    builder.initial_pose = sapien.Pose(p=[0, 0.2, 0.1])
    return builder.build(name=name)


def build_ring_stand(scene, name: str, color=(0.35, 0.35, 0.4, 1)):
    """A ring of `STAND_SEGMENTS` small boxes (1 cm wide, `STAND_HEIGHT` tall) round a circle of
    `STAND_RING_RADIUS`, standing on z = 0; kinematic (the table holds it)."""
    builder = scene.create_actor_builder()
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.6)
    seg = STAND_RING_RADIUS * np.sin(np.pi / STAND_SEGMENTS) + 0.002
    for k in range(STAND_SEGMENTS):
        a = 2 * np.pi * k / STAND_SEGMENTS
        pose = sapien.Pose(p=[STAND_RING_RADIUS * np.cos(a), STAND_RING_RADIUS * np.sin(a), STAND_HEIGHT / 2],
                           q=[np.cos(a / 2), 0, 0, np.sin(a / 2)])
        half = [0.004, seg, STAND_HEIGHT / 2]
        builder.add_box_collision(pose=pose, half_size=half)
        builder.add_box_visual(pose=pose, half_size=half, material=mat)
    builder.initial_pose = sapien.Pose(p=[0, 0.2, 0])
    return builder.build_kinematic(name=name)


def ball_rest_height() -> float:
    """Ball centre height when it sits in the stand: on the ring's inner top edges."""
    inner = STAND_RING_RADIUS - 0.004
    return STAND_HEIGHT + float(np.sqrt(BALL_RADIUS ** 2 - inner ** 2))


@register_task("HandoverBallHands")
class HandoverBallHandsEnv(HandoverTask):
    """**Task:** the left LEAP hand picks up a tennis ball from a ring stand on the left of the table and
    passes it to the right LEAP hand in mid-air.

    **Randomisation:** the ball (6.7 cm, 58 g) sits in its ring stand (4 cm ring, 1.5 cm tall, fixed to
    the table), the stand's centre uniform in x in [-0.15, -0.05], y in [0.12, 0.22].

    **Success:** (the Handover family rule, `HandoverTask`) the ball was handed over: the right hand held it
    (`ee.holds`: a finger against the thumb or palm, or the index/middle pinch) while the left hand neither
    held nor touched it and its centre was at least `lift_height` above the table, after the left hand had
    held it (episode memory `handed_over`); and now the right hand holds it, the left hand does not touch
    it (`ee.touches`) and its centre is at least `lift_height` above the table.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 8
    TASK_REGION = (-0.25, 0.05, -0.3, 0.3)
    PARAMS = HandoverTask.PARAMS

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.ball = build_ball(self.scene, "ball")
        self.stand = build_ring_stand(self.scene, "stand")
        self.item = self.ball

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xy = torch.stack([torch.rand(b) * 0.1 - 0.15, torch.rand(b) * 0.1 + 0.12], dim=1)
            self.stand.set_pose(Pose.create_from_pq(torch.cat([xy, torch.zeros(b, 1)], dim=1)))
            ball = torch.cat([xy, torch.full((b, 1), ball_rest_height() + 0.001)], dim=1)
            place_at_rest(self.ball, Pose.create_from_pq(ball))

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"])
        if "state" in self.obs_mode:
            obs.update(ball_pose=self.ball.pose.raw_pose,
                       left_tcp_to_ball=self.ball.pose.p - self.ee.tcp("left").p,
                       right_tcp_to_ball=self.ball.pose.p - self.ee.tcp("right").p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        ball = self.ball.pose.p
        left_reach = torch.linalg.norm(ball - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(ball - self.ee.tcp("right").p, dim=1)
        left, right = info["left_grasped"].float(), info["right_grasped"].float()
        height = (ball[:, 2] / self.lift_height).clamp(max=1)
        # stages: the left reaches and grasps and lifts; the right reaches the held ball and grasps it;
        # the left lets go
        reward = (1 - torch.tanh(5 * left_reach)) + left + left * height
        reward = torch.where(right.bool(), reward.clamp(min=3), reward)
        reward += 2 * (1 - torch.tanh(5 * right_reach)) * torch.maximum(left, right) + right
        reward += right * (1 - info["left_touch"].float()) * height
        reward[info["success"]] = self.max_dense_reward
        return reward


# ----------------------------------------------------------------------------------------------------
# solver: the left picks and carries, the right rolls palm-up and takes the ball from below (the "cradle").
# Measured alternatives (git history of wip/handover_ball_hands*.md): the right taking a top-down grasp of a ball
# the left holds palm-up, 5/50; the left letting go onto a flat palm-up right hand first, 0-1/10.
# ----------------------------------------------------------------------------------------------------
# palm-up by rolling in 12 waypoints of pi/12 about a TCP axis, 8 servo steps each (one 180-degree target and a
# joint-space path servoed one waypoint a step both fail to get there)
TAKER_ROLL_WAYPOINTS = 12
ROLL_STEPS = 8
# roll the right palm-up in the background while the left picks
MEET = (-0.1, 0.02, 0.36)  # left TCP during the handover: high enough for the palm-up right wrist (0.256 m below)
TAKER_ROLL_OFFSET = (0.0, -0.2, -0.12)  # where the right turns palm-up: clear of the ball and the left hand


# The giver holds the ball top-down with GIVER_SYNERGY: its contacts (index tip, middle tip, thumb tip) all sit at or
# above the ball's equator (measured in the ball frame: index +0.007, middle +0.015, thumb +0.031 m), so the lower
# hemisphere is free for a palm-up taker. The swap that works: the taker's palm comes up under the ball with a gap,
# the giver's joint targets are set to their MEASURED positions (its ~30 N squeeze drops to ~1 N with no finger
# motion, so nothing is stored to kick the ball), then in one phase the giver opens and rises while the taker closes.
# Ball on a flat palm rolls away at a ~1 degree tilt (0.1-0.3 m/s in 10-20 steps, measured), so the taker must close
# straight away, not after the giver has gone (release first, then close: 0/10; partial-open, lift, close: 2/10).
CRADLE_TAKER_YAW = -np.pi / 2  # top-down yaw the right rolls from (about its TCP y): palm-up, fingers towards +y
# the ball in the palm-up right TCP frame at the swap: 1 cm towards the thumb from the finger bases (so its +x side
# overlaps the raised ring finger, below), level with the thumb's row position, its bottom 4.5 mm above the palm
# (TCP z -0.08): a gap, so the taker's arm stores no push. (-0.02, 0, -0.042) with a flat ring: 42/50
CRADLE_BALL_IN_TAKER = (-0.01, 0.0, -0.042)
CRADLE_APPROACH = 0.05  # the right comes the last 5 cm straight up at 3 mm a step
# low dish once under the ball: index and middle raised 0.5 rad at the knuckle, the RING raised 1.4 rad, a post at
# the row's ring end (in 7 of the 12 failures without it the ball rolled 4-12 cm along the row, towards the ring, in
# the 20 steps after the giver let go, and off the palm or into the thumb/ring corner); thumb flat (a thumb raised
# to j12 1.0-1.6 pushes the ball 15-25 N into the giver and it flies off when the giver lets go: 1/10)
CRADLE_DISH = [0, 0.5, 0.2, 0.2] * 2 + [0, 1.4, 0.2, 0.2] + [0, 0, 0, 0]
CRADLE_TAKER_GRIP = LEAP_SYNERGIES["power"]
CRADLE_GIVER_OPEN_STEPS = 30  # the giver's targets ramp from its relaxed pose to open
CRADLE_TAKER_CLOSE_STEPS = 30  # ... while the taker ramps to its grip (20: 1/10, the fingers miss the rolled ball)
CRADLE_GIVER_RISE = 0.005  # metres a control step, from the first step of the swap, up to CRADLE_GIVER_LIFT
CRADLE_GIVER_LIFT = 0.08
CRADLE_SWAP_STEPS = 60
CRADLE_SQUEEZE = [0, 1.9, 1.0, 0.8] * 3 + [1.6, 0.6, 0.8, 0.8]


@register_solver("HandoverBallHands", control_modes=TCP_DELTA_MODES)
def solve_handover_ball_cradle(env, seed: int) -> dict:
    """The left picks top-down (GIVER_SYNERGY) and carries the ball to MEET while the right rolls palm-up in the
    background; the right comes up under the ball (a 4.5 mm gap) and raises a low dish; the left relaxes its grip
    to where its joints are; then together the left opens and rises and the right closes "power" round the ball."""
    with HandoverSolver.episode(env, seed) as s:
        task: HandoverBallHandsEnv = env.unwrapped
        dev, n = task.device, task.num_envs
        meet = torch.tensor([MEET], device=dev).expand(n, 3)
        aside = meet + torch.tensor(TAKER_ROLL_OFFSET, device=dev)
        s.background = roll_targets(s, "right_arm", CRADLE_TAKER_YAW, -1.0, aside, TAKER_ROLL_WAYPOINTS, ROLL_STEPS)
        s.pick("left_arm", "left_hand", task.ball.pose.p.clone(), 0.0, lift=0.12)
        s.move({"left_arm": (meet, top_down_quat(0.0, n, device=dev))}, max_steps=60, pos_tol=0.01)
        while s.background is not None:
            s.step()
        take_q = s.arm_targets["right_arm"][1]
        # right TCP from the ball: minus the ball's offset in the taker frame, turned into the world
        off = -(quaternion_to_matrix(take_q) @ torch.tensor(CRADLE_BALL_IN_TAKER, device=dev).reshape(1, 3, 1))[..., 0]
        down = torch.tensor([0.0, 0.0, 1.0], device=dev)
        s.move({"right_arm": (task.ball.pose.p + off - 0.1 * down, take_q)}, max_steps=60, pos_tol=0.01)
        s.set_ee("right_hand", "open", steps=5)
        s.move({"right_arm": (task.ball.pose.p + off - CRADLE_APPROACH * down, take_q)}, max_steps=30, pos_tol=0.004)
        glide(s, {"right_arm": (s.tcp("right_arm").p.clone(), task.ball.pose.p + off, take_q)}, step_length=0.003,
              settle_steps=10)
        s.close_hand("right_hand", CRADLE_DISH, ramp_steps=15, hold_steps=3)
        # relax: the giver's targets to its measured joint positions (its squeeze ~30 N -> ~1 N, nothing moves)
        relaxed = task.agent.controller.controllers["left_hand"].qpos.clone()
        s.close_hand("left_hand", relaxed, ramp_steps=5, hold_steps=5)
        giver0, taker0 = s.ee_cmd["left_hand"].clone(), s.ee_cmd["right_hand"].clone()
        grip = torch.as_tensor(np.asarray(CRADLE_TAKER_GRIP), dtype=torch.float32, device=dev)
        tcp = s.tcp("left_arm")
        lp, lq = tcp.p.clone(), tcp.q.clone()
        for k in range(1, CRADLE_SWAP_STEPS + 1):
            s.set_ee("left_hand", giver0 * (1 - min(k / CRADLE_GIVER_OPEN_STEPS, 1.0)), steps=0)
            s.set_ee("right_hand", taker0 + (grip - taker0) * min(k / CRADLE_TAKER_CLOSE_STEPS, 1.0), steps=0)
            s.step({"left_arm": (lp + min(k * CRADLE_GIVER_RISE, CRADLE_GIVER_LIFT) * down, lq)})
        # closed loop: the ball still on the right palm but no finger on it (it rolled into the thumb / ring corner,
        # where "power" fingers pass over it): curl the fingers further. Seeds 108 and 111 (ball at R-TCP
        # (-0.049, 0.06), palm + thumb DIP only): [0, 1.5, 1.4, 1.2] flings it off, [0, 1.9, 1.0, 0.8] holds it with
        # the ring tip (12 N) against the palm (13 N); the flat-ring dish went 38/50 -> 42/50 with this step
        # (or a grasp that flickers: a 0.1 N ring DIP, seed 141): any step of 5 without the grasp
        held = s.info["right_grasped"].clone()
        for _ in range(5):
            s.step()
            held &= s.info["right_grasped"]
        on_palm = (task.ball.pose.p - s.tcp("right_arm").p).norm(dim=1) < 0.1
        if bool((on_palm & ~held).any()):
            s.close_hand("right_hand", CRADLE_SQUEEZE, ramp_steps=20, hold_steps=5)
        s.hold_until_success()
        return s.info
