"""HandoverMugHands (L2 rigid DX, family Handover): an upside-down mug turned upright, handed over, set on a coaster."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_multiply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.mug import (MUG_DENSITY, MugShape, build_coaster, build_mug, mug_body_centre,
                                       placed_on_coaster)
from maniladder_ms.objects.tabletop import place_at_rest

from .base import HandoverTask

UPSIDE_DOWN = (0.0, 1.0, 0.0, 0.0)  # wxyz: half a turn about x


@register_task("HandoverMugHands")
class HandoverMugHandsEnv(HandoverTask):
    """**Task:** a mug stands upside down on the left of the table (as on a drying rack). The left LEAP hand
    picks it up, turns it upright and hands it to the right LEAP hand in mid-air; the right hand sets it
    upright on a round coaster on the right of the table and lets go.

    **Randomisation:**
    - the mug (8.4 cm wide, 9 cm tall, loop handle; ~0.13 kg) stands upside down on its rim, its centre uniform
      in x in `mug_x_range`, y in `mug_y_range`, its handle pointing away from the robot give or take
      `mug_max_yaw` (uniform);
    - the coaster (11 cm across, 5 mm thick, fixed to the table) has its centre uniform in x in
      `coaster_x_range`, y in `coaster_y_range`.

    **Success:** (the Handover family rule, `HandoverTask`, hand to hand) the mug was handed over: both hands
    held it at once (`ee.holds` for the left and the right) with its centre at least `lift_height` above the
    table (episode memory `both_held`), and later the right hand held it while the left hand neither held nor
    touched it (`ee.touches`), its centre still at least `lift_height` up (episode memory `handed_over`); and
    now the mug is upright (its axis tilted by less than `max_tilt`), its bottom centre within `centre_tol`
    (horizontally) of the coaster's centre and resting on the coaster (within `rest_tol` of its top), and
    neither hand touches it (released).

    **Level 2:** (against Level 1's HandoverBallHands, a pick and a pass that ends with the ball in the right
    hand: 2 stages) 4 stages (pick, turn the mug upright in the left hand, hand to hand pass, set down and
    release); the mug is turned half a turn in the giver's hand, both hands must hold it at once, and it must
    end within 2 cm of the coaster's centre and 10 degrees of upright, released: 599-1011 control steps (mean 754)
    (HandoverBallHands' solver: 279).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 10
    TASK_REGION = (-0.25, 0.05, -0.35, 0.3)
    PARAMS = HandoverTask.PARAMS + ("max_tilt", "centre_tol", "rest_tol", "mug_x_range", "mug_y_range",
                                    "mug_max_yaw", "coaster_x_range", "coaster_y_range")
    HAND_TO_HAND = True
    mug_shape = MugShape()

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.mug = build_mug(self.scene, "mug", self.mug_shape, color=(0.25, 0.45, 0.75, 1), friction=1.0,
                             density=MUG_DENSITY)
        self.coaster = build_coaster(self.scene, "coaster")
        self.item, self.target = self.mug, self.coaster

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.mug_x_range), uniform(b, self.mug_y_range),
                               torch.full((b,), self.mug_shape.body.height)], dim=1)
            # the handle (the mug's -x side) points away from the robot (world +x), give or take mug_max_yaw;
            # flipped about x, the mug's -x stays -x: a yaw of pi turns it to +x
            handle_yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(self.mug_max_yaw)
            flip = torch.tensor(UPSIDE_DOWN).expand(b, 4)
            place_at_rest(self.mug, Pose.create_from_pq(xyz, quaternion_multiply(yaw_quat(handle_yaw + np.pi), flip)))
            coaster = torch.stack([uniform(b, self.coaster_x_range), uniform(b, self.coaster_y_range), torch.zeros(b)],
                                  dim=1)
            self.coaster.set_pose(Pose.create_from_pq(coaster))

    def item_centre(self) -> torch.Tensor:
        return mug_body_centre(self.mug, self.mug_shape)

    def _placed(self, info: dict) -> torch.Tensor:
        return placed_on_coaster(self.mug, self.coaster, self.max_tilt, self.centre_tol, self.rest_tol, info)

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"],
                   handed_over=info["handed_over"])
        if "state" in self.obs_mode:
            centre = self.item_centre()
            obs.update(mug_pose=self.mug.pose.raw_pose, coaster_pos=self.coaster.pose.p,
                       mug_to_coaster=self.coaster.pose.p - self.mug.pose.p,
                       left_tcp_to_mug=centre - self.ee.tcp("left").p, right_tcp_to_mug=centre - self.ee.tcp("right").p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        centre = self.item_centre()
        left_reach = torch.linalg.norm(centre - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(centre - self.ee.tcp("right").p, dim=1)
        left, right = info["left_grasped"].float(), info["right_grasped"].float()
        height = (centre[:, 2] / self.lift_height).clamp(max=1)
        upright = 1 - info["tilt"] / np.pi
        # stages: the left reaches, grasps and lifts (turning the mug upright); the right reaches the held mug,
        # both hold it; the left lets go; the right carries it over the coaster and sets it down; both off it
        reward = (1 - torch.tanh(5 * left_reach)) + left + left * height * upright
        reward = torch.where(info["both_held"], reward.clamp(min=3) + 1, reward)
        reward += (1 - torch.tanh(5 * right_reach)) * torch.maximum(left, right)
        gap = torch.linalg.norm((self.coaster.pose.p - self.mug.pose.p)[:, :2], dim=1)
        after = 6 + 2 * (1 - torch.tanh(5 * gap)) * upright + info["placed"].float()
        reward = torch.where(info["handed_over"], after, reward)
        reward[info["success"]] = self.max_dense_reward
        return reward
