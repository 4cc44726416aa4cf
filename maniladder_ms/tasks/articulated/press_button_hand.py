"""PressButtonHand (L1 rigid SX): press a push button down with the LEAP hand's index finger."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import TOUCH_FORCE, link_forces
from maniladder_ms.agents.effectors import leap_fingertip
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.controls import ButtonShape, build_push_button, button_travel


@register_task("PressButtonHand")
class PressButtonHandEnv(ManiLadderEnv):
    """**Task:** press a push button (a round cap of radius `cap_radius` on a 9 cm housing, 1.2 cm travel,
    spring-returned) all the way down with the LEAP hand's index finger.

    **Randomisation:** the button's centre uniform in x in `button_x_range`, y in `button_y_range`; its
    housing's yaw uniform in `button_yaw_range` (the square housing looks the same every quarter turn).

    **Success:** the cap is pressed down by at least `press_fraction` of its travel, and the index finger
    presses on it (one of its links, `INDEX_LINKS`, above the vocabulary's touch force): the spring pushes
    a cap back up at once, so the finger touching it now is what holds it down.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 4
    PARAMS = ("press_fraction", "cap_radius", "button_x_range", "button_y_range", "button_yaw_range")
    TASK_REGION = (-0.27, 0.02, -0.22, 0.22)  # holds the button centres plus the housing's half diagonal, with room
    # the index finger's links: the catalog asks for the press to be made with the index finger (not the
    # palm, another finger or the arm); the vocabulary's `ee.touches` has no per-finger form yet
    INDEX_LINKS = ("leap_index_pip", "leap_index_dip", "leap_index_tip")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.button_shape = replace(ButtonShape(), cap_radius=self.cap_radius)
        self.button = build_push_button(self.scene, "button", self.button_shape, housing_color=(0.3, 0.3, 0.32, 1),
                                        cap_color=(0.85, 0.1, 0.1, 1))
        self.cap = self.button.links_map["button_cap"]

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.button_x_range), uniform(b, self.button_y_range), torch.zeros(b)], dim=1)
            self.button.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.button_yaw_range))))
            self.button.set_qpos(torch.zeros(b, 1))
            self.button.set_qvel(torch.zeros(b, 1))

    def cap_top(self) -> torch.Tensor:
        """(num_envs, 3) world position of the released cap's top centre."""
        return self.button.pose.p + torch.tensor([0, 0, self.button_shape.cap_top], device=self.device)

    def index_touches_cap(self) -> torch.Tensor:
        """(num_envs,) bool: a link of the index finger presses on the cap."""
        links = [self.ee["main"].link(name) for name in self.INDEX_LINKS]
        return (link_forces(self.scene, self.cap, links) >= TOUCH_FORCE).any(dim=0)

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(button_pose=self.button.pose.raw_pose, travel=info["travel"],
                       fingertip_to_cap=self.cap_top() - leap_fingertip(self.agent))
        return obs

    def evaluate(self):
        travel = button_travel(self.button)
        is_pressed = travel >= self.press_fraction * self.button_shape.travel
        is_index_on_cap = self.index_touches_cap()
        return {"success": is_pressed & is_index_on_cap, "travel": travel, "is_pressed": is_pressed,
                "is_index_on_cap": is_index_on_cap}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.cap_top() - leap_fingertip(self.agent), dim=1))
        press = (info["travel"] / (self.press_fraction * self.button_shape.travel)).clamp(0, 1)
        reward = reach + 2 * press
        reward[info["success"]] = self.max_dense_reward
        return reward
