"""HandoverBallHands (L1 rigid DX, family Handover): pass a tennis ball from the left LEAP hand to the right one."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.layout import uniform
from maniladder_ms.objects.tabletop import place_at_rest

from .base import HandoverTask

BALL_RADIUS = 0.0335  # a tennis ball: 6.7 cm across, 58 g
BALL_MASS = 0.058
BALL_FRICTION = 0.8  # felt
# the stand: a ring of small boxes the ball sits in, so that it does not roll away before the pick
STAND_RING_RADIUS = 0.02  # to the boxes' centres
STAND_HEIGHT = 0.015
STAND_SEGMENTS = 12
BALL_DROP = 0.001  # the ball starts this far above its rest height in the stand and settles onto it (`place_at_rest`)


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
    the table), the stand's centre uniform in x in `stand_x_range`, y in `stand_y_range`.

    **Success:** (the Handover family rule, `HandoverTask`) the ball was handed over: the right hand held it
    (`ee.holds`: a finger against the thumb or palm, or the index/middle pinch) while the left hand neither
    held nor touched it and its centre was at least `lift_height` above the table, after the left hand had
    held it (episode memory `handed_over`); and now the right hand holds it, the left hand does not touch
    it (`ee.touches`) and its centre is at least `lift_height` above the table.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 8
    TASK_REGION = (-0.25, 0.05, -0.3, 0.3)
    PARAMS = HandoverTask.PARAMS + ("stand_x_range", "stand_y_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.ball = build_ball(self.scene, "ball")
        self.stand = build_ring_stand(self.scene, "stand")
        self.item = self.ball

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xy = torch.stack([uniform(b, self.stand_x_range), uniform(b, self.stand_y_range)], dim=1)
            self.stand.set_pose(Pose.create_from_pq(torch.cat([xy, torch.zeros(b, 1)], dim=1)))
            ball = torch.cat([xy, torch.full((b, 1), ball_rest_height() + BALL_DROP)], dim=1)
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
