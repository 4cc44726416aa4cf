"""PlaceMugOnCoasterHand (L2 rigid SX): one LEAP hand grasps a mug by its body and sets it upright on a coaster."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import tilt, yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.mug import (MUG_DENSITY, MugShape, build_coaster, build_mug, mug_body_centre,
                                       placed_on_coaster)
from maniladder_ms.objects.tabletop import place_at_rest


@register_task("PlaceMugOnCoasterHand")
class PlaceMugOnCoasterHandEnv(ManiLadderEnv):
    """**Task:** a mug stands upright on the table, a round coaster lies beside it; the LEAP hand grasps the
    mug by its body, lifts it, carries it over the coaster, sets it down upright on it and lets go.

    **Randomisation:** the mug (8.4 cm wide, 9 cm tall, loop handle; ~0.13 kg; `objects.mug`) stands upright,
    its centre uniform in x in `mug_x_range`, y in `mug_y_range`, its yaw uniform in `mug_yaw_range` (the handle
    pointing to the robot's left, away from the coaster, within 45 degrees of +y); the coaster (11 cm across,
    5 mm thick, fixed to the table) has its centre uniform in x in `coaster_x_range`, y in `coaster_y_range`
    (a 13.5-30 cm carry).

    **Success:** the mug was carried: at some control step the hand held it (`ee.holds`: a finger pressing
    against the thumb or palm) with its body at least `lift_height` clear of the table (its lowest point; episode
    memory `carried`); and now the mug is upright (its axis tilted by less than `max_tilt`), its bottom centre is
    within `centre_tol` (horizontally) of the coaster's centre, its bottom rests on the coaster (within
    `rest_tol` of the coaster's top), and no part of the hand touches it (`ee.touches`: released).

    **Level 2:** (against Level 1's LiftBottleHand: one power grasp and a lift, 2 stages, ~80-step demos, no
    placement, no release) 4 stages (grasp, lift and carry 13.5-30 cm, set down, release), ~200-step demos; the
    mug hangs in the grip tilted by 5-25 degrees and must end within 2 cm of the coaster's centre and 10 degrees
    of upright, so the wrist takes the tilt out before the set-down; and the hand must open off the standing mug
    without pushing or tipping it: the fingers opening straight from the power grasp throw it 8-10 cm or tip
    it over (3 of 3 seeds), so the release is a stage of its own (relax the squeeze, fingers, then thumb).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 8
    TASK_REGION = (-0.29, -0.01, -0.21, 0.24)  # the mug with its handle (8 cm from the axis) and the coaster
    PARAMS = ("lift_height", "max_tilt", "centre_tol", "rest_tol",
              "mug_x_range", "mug_y_range", "mug_yaw_range", "coaster_x_range", "coaster_y_range")
    mug_shape = MugShape()

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.mug = build_mug(self.scene, "mug", self.mug_shape, color=(0.25, 0.45, 0.75, 1), friction=1.0,
                             density=MUG_DENSITY)
        self.coaster = build_coaster(self.scene, "coaster")
        self.memory.flag("carried")  # held by the hand with its body lift_height clear of the table

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            mug = torch.stack([uniform(b, self.mug_x_range), uniform(b, self.mug_y_range), torch.zeros(b)], dim=1)
            place_at_rest(self.mug, Pose.create_from_pq(mug, yaw_quat(uniform_deg(b, self.mug_yaw_range))))
            coaster = torch.stack([uniform(b, self.coaster_x_range), uniform(b, self.coaster_y_range), torch.zeros(b)],
                                  dim=1)
            self.coaster.set_pose(Pose.create_from_pq(coaster))

    def mug_centre(self) -> torch.Tensor:
        """World centre of the mug's body (half its height up its axis), (num_envs, 3)."""
        return mug_body_centre(self.mug, self.mug_shape)

    def clearance(self) -> torch.Tensor:
        """(num_envs,) height above the table of the lowest point of the mug's body (a cylinder; a mug lying on its
        side has its bottom centre 4 cm up but its wall on the table)."""
        theta, shape = tilt(self.mug), self.mug_shape
        lowest = torch.clamp(shape.body.height * torch.cos(theta), max=0) - shape.outer_radius * torch.sin(theta)
        return self.mug.pose.p[:, 2] + lowest

    def _update_memory(self):
        up = (self.clearance() >= self.lift_height) & ~self.memory["carried"]
        if bool(up.any()):  # the contact pass only where it can latch
            self.memory.latch("carried", up & self.ee.holds(self.mug))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"], carried=info["carried"])
        if "state" in self.obs_mode:
            obs.update(mug_pose=self.mug.pose.raw_pose, coaster_pos=self.coaster.pose.p,
                       mug_to_coaster=self.coaster.pose.p - self.mug.pose.p,
                       tcp_to_mug=self.mug_centre() - self.ee.tcp().p)
        return obs

    def evaluate(self):
        info = dict(height=self.clearance(), is_grasped=self.ee.holds(self.mug),
                    touched=self.ee.touches(self.mug), carried=self.memory["carried"])
        info["placed"] = placed_on_coaster(self.mug, self.coaster, self.max_tilt, self.centre_tol, self.rest_tol, info)
        info["released"] = ~info["touched"]
        info["success"] = info["carried"] & info["placed"] & info["released"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach the mug, grasp it, lift it (carried), bring it over the coaster upright, set it down, let go
        reach = torch.linalg.norm(self.mug_centre() - self.ee.tcp().p, dim=1)
        grasped, carried = info["is_grasped"].float(), info["carried"].float()
        lift = (info["height"] / self.lift_height).clamp(0, 1)
        upright = 1 - info["tilt"] / np.pi
        gap = torch.linalg.norm((self.coaster.pose.p - self.mug.pose.p)[:, :2], dim=1)
        reward = (1 - torch.tanh(5 * reach)) + grasped + grasped * lift * (1 - carried)
        reward += carried * (1 + 2 * (1 - torch.tanh(5 * gap)) * upright + info["placed"].float()
                             + (info["placed"] & info["released"]).float())
        reward[info["success"]] = self.max_dense_reward
        return reward
