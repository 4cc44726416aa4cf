"""TurnValveHand (L1 rigid SX): turn a wheel valve by `turn_angle` (70 degrees) the way an arrow shows, with the LEAP
hand."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import leap_fingertip
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.controls import ValveShape, build_turn_arrow, build_wheel_valve, turn_direction, valve_angle


@register_task("TurnValveHand")
class TurnValveHandEnv(ManiLadderEnv):
    """**Task:** turn a hand-wheel valve (17 cm wheel, 4 spokes, on a 10 cm stem; the wheel turns about
    the vertical) by `turn_angle` (70 degrees) in the direction a curved yellow arrow on the table shows.

    **Randomisation:** the valve's centre uniform in x in `valve_x_range`, y in `valve_y_range`; its yaw (where
    the spokes point) uniform in `valve_yaw_range`; the direction clockwise (seen from above) with probability
    `clockwise_probability`, else counter-clockwise, and the arrow's place on its arc (`ARROW_RADIUS` round the
    valve) uniform in `arrow_yaw_range`. The wheel starts at joint angle 0.

    **Success:** the hand has turned the wheel by at least `turn_angle` in the arrow's direction: the
    episode memory sums the wheel's turn (in the arrow's direction, turning back counts against it) over
    the control steps in which the hand touches the wheel (`ee.touches`, at the step's start or end);
    a turn made by the arm's links or by a spin the hand did not drive does not count. (The wheel
    stops as soon as nothing pushes it: its joint's damping.)
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.36, 0.06, -0.26, 0.26)  # valve region plus the arrow around it (16 cm)
    PARAMS = ("turn_angle",  # degrees
              "valve_x_range", "valve_y_range", "valve_yaw_range", "arrow_yaw_range", "clockwise_probability")
    valve_shape = ValveShape()
    ARROW_RADIUS = 0.13  # m: the arrow lies on the table on an arc around the valve, outside the wheel
    ARROW_LIFT = 0.001  # m above the table top (drawn over it)

    def _load_scene(self, options: dict):
        if not 0 <= self.clockwise_probability <= 1:
            raise ValueError(f"clockwise_probability must be in [0, 1], got {self.clockwise_probability}")
        super()._load_scene(options)
        self.valve = build_wheel_valve(self.scene, "valve", self.valve_shape, stand_color=(0.45, 0.45, 0.48, 1),
                                       wheel_color=(0.75, 0.1, 0.1, 1), marker_color=(0.95, 0.95, 0.95, 1))
        self.arrow = build_turn_arrow(self.scene, "turn_arrow", self.ARROW_RADIUS, color=(0.95, 0.8, 0.1, 1))
        self.wheel = self.valve.links_map["valve_wheel"]
        self.memory.value("last_angle")  # the wheel's angle after the last step
        self.memory.value("last_touch")  # 1 where the hand touched the wheel after the last step
        self.memory.value("hand_turn")  # rad turned in the arrow's direction in steps the hand touched it

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.valve_x_range), uniform(b, self.valve_y_range), torch.zeros(b)], dim=1)
            self.valve.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.valve_yaw_range))))
            self.valve.set_qpos(torch.zeros(b, 1))
            self.valve.set_qvel(torch.zeros(b, 1))
            # the arrow points counter-clockwise face up; upside down (pi about its x axis) clockwise
            clockwise = torch.rand(b) < self.clockwise_probability
            flip = torch.where(clockwise[:, None], torch.tensor([0.0, 1.0, 0.0, 0.0]), torch.tensor([1.0, 0.0, 0.0, 0.0]))
            place = Pose.create_from_pq(xyz + torch.tensor([0, 0, self.ARROW_LIFT]),
                                        yaw_quat(uniform_deg(b, self.arrow_yaw_range)))
            self.arrow.set_pose(place * Pose.create_from_pq(q=flip))
            self.memory.store("last_angle", torch.zeros(b, 1), env_idx)

    def hub(self) -> torch.Tensor:
        """(num_envs, 3) world centre of the wheel's hub (the valve's axis at the wheel)."""
        return self.valve.pose.p + torch.tensor([0, 0, self.valve_shape.height], device=self.device)

    def turned(self) -> torch.Tensor:
        """(num_envs,) how far (rad) the wheel has turned from its start in the arrow's direction."""
        return turn_direction(self.arrow) * valve_angle(self.valve)

    def _update_memory(self):
        super()._update_memory()
        angle = valve_angle(self.valve)
        touch = self.ee.touches(self.wheel)
        by_hand = touch | (self.memory["last_touch"][:, 0] > 0.5)
        delta = turn_direction(self.arrow) * (angle - self.memory["last_angle"][:, 0])
        self.memory.store("hand_turn", self.memory["hand_turn"] + torch.where(by_hand, delta, 0.0)[:, None])
        self.memory.store("last_angle", angle[:, None])
        self.memory.store("last_touch", touch.float()[:, None])

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(valve_pose=self.valve.pose.raw_pose, valve_angle=valve_angle(self.valve),
                       direction=turn_direction(self.arrow), fingertip=leap_fingertip(self.agent))
        return obs

    def evaluate(self):
        hand_turned = self.memory["hand_turn"][:, 0]
        return {"success": hand_turned >= np.deg2rad(self.turn_angle), "turned": self.turned(),
                "hand_turned": hand_turned}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.hub() - leap_fingertip(self.agent), dim=1))
        progress = (info["hand_turned"] / np.deg2rad(self.turn_angle)).clamp(0, 1)
        reward = reach + 3 * progress
        reward[info["success"]] = self.max_dense_reward
        return reward

