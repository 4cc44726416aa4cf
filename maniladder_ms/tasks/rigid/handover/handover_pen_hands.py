"""HandoverPenHands (L3 rigid DX, family Handover): a thin pen passed from the left LEAP hand's two-finger pinch to the
right one's, never set down."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import contact_forces
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects import build_pen

from .base import HandoverTask


@register_task("HandoverPenHands")
class HandoverPenHandsEnv(HandoverTask):
    """**Task:** a thin pen lies on the left of the table. The left LEAP hand picks it up, the right LEAP hand takes
    it from the left one in mid-air, and the left hand lets go: the right hand ends holding the pen up in the air.
    The pen must not touch the table again once picked.

    **Randomisation:** the pen (`pen_length` long, 2 x `pen_radius` thick) lies flat, its centre uniform in x in
    `PEN_X` = [-0.15, -0.05], y in `PEN_Y` = [0.12, 0.2], its axis within +-`PEN_MAX_YAW` = +-30 degrees of the
    table's y axis (either end towards the robot's right).

    **Success:** (the Handover family rule, `HandoverTask`, hand to hand, the giver alone first) the pen was handed
    over: the left hand held it (`ee.holds`) while the right hand neither held nor touched it (`ee.touches`) and
    its centre was at least `lift_height` above the table (episode memory `giver_held`), later both hands held it
    at once with its centre at least `lift_height` up (`both_held`), later the right hand held it while the left
    hand neither held nor touched it, its centre still at least `lift_height` up (`handed_over`); the pen has not
    touched the table since the left hand first held it lifted (episode memory `dropped`, never set); and now the
    right hand holds it, the left hand does not touch it and its centre is at least `lift_height` above the table.

    **Level 3:** (against Level 2's HandoverMugHands, an 8.4 cm mug passed between two power grasps) the object is a
    1.6 cm thick pen, taken and held only between two straight fingers (the index / middle "scissor" pinch, whose
    tips reach to within 8 mm of the table: a 1.6 cm object lying flat is at the limit of what a LEAP hand picks
    up; no thumb-index pinch takes it); both pinches share one 14 cm pen, 11 cm apart, so the two hands' knuckles
    work within a few centimetres of each other (at 7-9 cm apart the hands collide and push the pen out of the
    giver's pinch); the pass has three ordered holding stages (left alone, both, right alone) and a pen dropped or
    set on the table at any time after the pick fails the episode (no regrasp from the table). The scripted pass
    takes 174-207 control steps (mean 190).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 8
    TASK_REGION = (-0.25, 0.05, -0.3, 0.3)
    PARAMS = HandoverTask.PARAMS + ("pen_length", "pen_radius")
    HAND_TO_HAND = True
    GIVER_ALONE_FIRST = True
    PEN_X, PEN_Y = (-0.15, 0.1), (0.12, 0.08)  # layout ranges as (low, span)
    PEN_MAX_YAW = np.deg2rad(30.0)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.memory.flag("dropped")  # the pen touched the table after the giver had held it lifted
        self.pen = build_pen(self.scene, "pen", self.pen_length, self.pen_radius, body_color=(0.1, 0.25, 0.75, 1),
                             cap_color=(0.9, 0.9, 0.9, 1))
        self.item = self.pen

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([torch.rand(b) * self.PEN_X[1] + self.PEN_X[0],
                               torch.rand(b) * self.PEN_Y[1] + self.PEN_Y[0],
                               torch.full((b,), self.pen_radius)], dim=1)
            # the pen's local x is its axis: along the table's y, give or take PEN_MAX_YAW, either way round
            yaw = np.pi / 2 + (torch.rand(b) * 2 - 1) * self.PEN_MAX_YAW + torch.where(torch.rand(b) < 0.5, 0.0, np.pi)
            self.pen.set_pose(Pose.create_from_pq(xyz, yaw_quat(yaw)))

    def on_table(self) -> torch.Tensor:
        """(num_envs,) bool: the pen touches the table."""
        return contact_forces(self.scene, self.ladder_scene.table, [self.pen])[0].norm(dim=1) > 1e-3

    def _update_memory(self):
        super()._update_memory()
        self.memory.latch("dropped", self.memory["giver_held"] & self.on_table())

    def evaluate(self):
        info = super().evaluate()
        info["on_table"] = self.on_table()
        info["dropped"] = self.memory["dropped"]
        info["success"] = info["success"] & ~info["dropped"]
        return info

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"],
                   handed_over=info["handed_over"])
        if "state" in self.obs_mode:
            obs.update(pen_pose=self.pen.pose.raw_pose,
                       left_tcp_to_pen=self.pen.pose.p - self.ee.tcp("left").p,
                       right_tcp_to_pen=self.pen.pose.p - self.ee.tcp("right").p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        pen = self.pen.pose.p
        left_reach = torch.linalg.norm(pen - self.ee.tcp("left").p, dim=1)
        right_reach = torch.linalg.norm(pen - self.ee.tcp("right").p, dim=1)
        left, right = info["left_grasped"].float(), info["right_grasped"].float()
        height = (pen[:, 2] / self.lift_height).clamp(max=1)
        # stages: the left reaches, pinches and lifts; the right reaches the held pen and pinches it too (both
        # hold); the left lets go and keeps off; a pen back on the table earns nothing
        reward = (1 - torch.tanh(5 * left_reach)) + left + left * height
        reward = torch.where(info["giver_held"], reward.clamp(min=3), reward)
        reward += (1 - torch.tanh(5 * right_reach)) * info["giver_held"].float() + right
        reward = torch.where(info["both_held"], reward.clamp(min=5) + right * (1 - info["left_touch"].float()), reward)
        reward = torch.where(info["dropped"], torch.zeros_like(reward), reward)
        reward[info["success"]] = self.max_dense_reward
        return reward
