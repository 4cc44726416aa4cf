"""CarryBoxToShelfHands (L2 rigid DX): carry a carton squeezed between both LEAP palms onto a raised shelf."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.boxes import build_carton
from maniladder_ms.objects.tabletop import build_shelf

SIDES = {"left": 1, "right": -1}  # the left palm presses the carton's +y side
PALM_DEPTH = 0.081  # the LEAP palm's face lies this far behind the TCP, along the TCP's z axis (out of the palm)
GRIP_HEIGHT = 0.13  # the TCPs this far above the carton's bottom: the wrists (Panda link 7) clear the table
GRIP_BACK = 0.02  # the TCPs this far behind the carton's centre (along its x): the finger row lies along the side
CLEARANCE = 0.05  # the carton's bottom rises this far above the shelf's top for the carry


@register_task("CarryBoxToShelfHands")
class CarryBoxToShelfHandsEnv(ManiLadderEnv):
    """**Task:** a closed carton stands on the table in front of the robot; a shelf stands farther out. Both LEAP
    hands squeeze the carton between their palms from its two sides, lift it together, carry it over the
    shelf, set it down on the shelf board and let go.

    **Randomisation:** the carton (2 x `box_half`, `box_mass`) stands with its centre uniform in x in
    `box_x_range`, y in `box_y_range` and its yaw uniform within +-`box_max_yaw`; the shelf (a board
    2 x `shelf_half`, its top `shelf_height` above the table, on two side panels) stands with its centre uniform
    in x in `shelf_x_range`, y in `shelf_y_range`, axis-aligned.

    **Success:** the carton was carried by both hands: at some control step each hand held it (`ee.holds` for
    the left and the right) while its lowest bottom corner was at least `lift_height` above the table and it was
    not standing on the shelf (episode memory `carried`); and now it stands on the shelf: each of its four
    bottom corners (of the carton, half sizes `box_half`, mass `box_mass`) lies within `rest_tol` in height of the
    board's top face (`shelf_height` above the table) and inside the board's top rectangle (half sizes `shelf_half`,
    the shelf footprint), and neither hand touches it (`ee.touches`).

    **Level 2:** (against Level 1's LiftBasketHands, the same two-LEAP-hand lift: 2 stages, grasp and lift,
    158 steps mean, handles the fingers hook under) 4 stages, ~178 steps mean: press both palms on the
    carton's flat sides, lift it 20 cm (over a 15 cm high shelf), carry it 25-37 cm, set it down and let go.
    The carton has no handle: it is held only by the two arms pressing their palms together (friction), so
    both arms' targets move in lock-step through the ~110 steps of lift, carry and set-down, and it must
    land with all four corners on the 22 x 34 cm board (2.4 cm of play along x at a 10 degree yaw).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 10
    TASK_REGION = (-0.34, 0.24, -0.3, 0.3)
    PARAMS = ("lift_height", "shelf_height", "shelf_half", "box_half", "box_mass", "rest_tol",
              "box_x_range", "box_y_range", "box_max_yaw", "shelf_x_range", "shelf_y_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.box = build_carton(self.scene, "carton", self.box_half, self.box_mass, color=(0.72, 0.55, 0.35, 1))
        self.shelf = build_shelf(self.scene, "shelf", self.shelf_half, self.shelf_height, color=(0.45, 0.32, 0.22, 1))
        self.memory.flag("carried")  # held by both hands, off the table and not on the shelf

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            box = torch.stack([uniform(b, self.box_x_range), uniform(b, self.box_y_range), torch.zeros(b)], dim=1)
            box_yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(self.box_max_yaw)
            self.box.set_pose(Pose.create_from_pq(box, yaw_quat(box_yaw)))
            shelf = torch.stack([uniform(b, self.shelf_x_range), uniform(b, self.shelf_y_range), torch.zeros(b)], dim=1)
            self.shelf.set_pose(Pose.create_from_pq(shelf))

    def bottom_corners(self) -> torch.Tensor:
        """(num_envs, 4, 3) world positions of the carton's four bottom corners."""
        hx, hy, _ = self.box_half
        local = torch.tensor([[sx * hx, sy * hy, 0.0] for sx in (1, -1) for sy in (1, -1)], device=self.device)
        pose = self.box.pose
        q = pose.q[:, None].expand(-1, 4, -1)
        return pose.p[:, None] + quaternion_apply(q, local[None].expand(self.num_envs, -1, -1))

    def _on_shelf(self, corners: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(level on the board's top within `rest_tol`, inside the board's top rectangle), (num_envs,) each."""
        rel = corners - self.shelf.pose.p[:, None]
        resting = ((rel[..., 2] - self.shelf_height).abs() <= self.rest_tol).all(dim=1)
        inside = ((rel[..., 0].abs() <= self.shelf_half[0]) & (rel[..., 1].abs() <= self.shelf_half[1])).all(dim=1)
        return resting, inside

    def grip_points(self) -> dict[str, tuple[torch.Tensor, torch.Tensor, torch.Tensor]]:
        """Per side, (TCP position, palm normal, carton's x axis), (num_envs, 3) each: where that hand's TCP puts
        its palm flat on the carton's side (`GRIP_HEIGHT` above the bottom, `GRIP_BACK` behind the centre), the
        normal pointing into the carton. The observation and the reward use the position; the solver turns the
        rest into the TCP's orientation."""
        pose = self.box.pose
        ex = quaternion_apply(pose.q, torch.tensor([[1.0, 0.0, 0.0]], device=self.device).expand(self.num_envs, 3))
        ey = quaternion_apply(pose.q, torch.tensor([[0.0, 1.0, 0.0]], device=self.device).expand(self.num_envs, 3))
        up = quaternion_apply(pose.q, torch.tensor([[0.0, 0.0, 1.0]], device=self.device).expand(self.num_envs, 3))
        points = {}
        for side, sign in SIDES.items():
            normal = -sign * ey
            face = pose.p + sign * self.box_half[1] * ey + GRIP_HEIGHT * up - GRIP_BACK * ex
            points[side] = (face + PALM_DEPTH * normal, normal, ex)
        return points

    def _update_memory(self):
        corners = self.bottom_corners()
        resting, inside = self._on_shelf(corners)
        up = (corners[..., 2].min(dim=1).values >= self.lift_height) & ~(resting & inside) & ~self.memory["carried"]
        if bool(up.any()):
            self.memory.latch("carried", up & self.ee.holds(self.box, "left") & self.ee.holds(self.box, "right"))

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   left_grasped=info["left_grasped"], right_grasped=info["right_grasped"], carried=info["carried"])
        if "state" in self.obs_mode:
            grips = self.grip_points()
            obs.update(box_pose=self.box.pose.raw_pose, shelf_pos=self.shelf.pose.p,
                       box_to_shelf=self.shelf.pose.p - self.box.pose.p,
                       left_tcp_to_grip=grips["left"][0] - self.ee.tcp("left").p,
                       right_tcp_to_grip=grips["right"][0] - self.ee.tcp("right").p)
        return obs

    def evaluate(self):
        corners = self.bottom_corners()
        resting, inside = self._on_shelf(corners)
        info = {f"{side}_grasped": self.ee.holds(self.box, side) for side in SIDES}
        touching = self.ee.touches(self.box, "left") | self.ee.touches(self.box, "right")
        info.update(height=corners[..., 2].min(dim=1).values, on_shelf=resting, inside_footprint=inside,
                    released=~touching, carried=self.memory["carried"])
        info["is_lifted"] = info["height"] >= self.lift_height
        info["success"] = info["carried"] & resting & inside & info["released"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach each side and hold it; lift with both hands (kept once carried); then over the shelf, down on it,
        # let go
        grips = self.grip_points()
        reward = torch.zeros(self.num_envs, device=self.device)
        for side in SIDES:
            reach = torch.linalg.norm(grips[side][0] - self.ee.tcp(side).p, dim=1)
            reward += 0.5 * (1 - torch.tanh(5 * reach)) + 0.5 * info[f"{side}_grasped"]
        both = info["left_grasped"] & info["right_grasped"]
        lift = (info["height"] / (self.shelf_height + CLEARANCE)).clamp(0, 1)
        reward += 2 * torch.where(info["carried"], 1.0, both * lift)
        gap = torch.linalg.norm((self.shelf.pose.p - self.box.pose.p)[:, :2], dim=1)
        placed = info["on_shelf"] & info["inside_footprint"]
        reward += info["carried"] * (2 * (1 - torch.tanh(5 * gap)) + 2 * placed + placed * info["released"])
        reward[info["success"]] = self.max_dense_reward
        return reward
