"""PingPongTransport (L2 rigid DG, family LiftTwoHanded): carry a tray with a ping-pong ball on it with both arms."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply, quaternion_invert
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import register_task
from maniladder_ms.geometry import tilt, yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.markers import MARKER_THICKNESS, build_zone_marker
from maniladder_ms.objects.tabletop import build_ping_pong_ball, build_serving_tray, place_at_rest

from .base import SIDE_SIGNS, LiftTwoHandedTask
TRAY_INNER_HALF = (0.1, 0.15)  # the floor inside the rims, (x, y): 20 x 30 cm
TRAY_WALL, TRAY_BASE, TRAY_END_HEIGHT = 0.01, 0.008, 0.06


@register_task("PingPongTransport")
class PingPongTransportEnv(LiftTwoHandedTask):
    """**Task:** a serving tray stands on the table near the robot with a ping-pong ball lying on it; both arms
    take the tray by its two end walls, lift it, carry it to a target zone at the far side of the table and set
    it down there, keeping the ball on the tray.

    **Randomisation:** the tray (floor 20 x 30 cm inside, low rims `rim_height` high along its front and back,
    6 cm end walls at +-y, ~0.45 kg) stands with its centre uniform in x in `tray_x_range`, y in `tray_y_range`
    and its yaw uniform in +-`tray_max_yaw`; the ball (`ball_radius`, `ball_mass`, a hollow shell) lies on the
    tray floor, uniform in `ball_dx_range` x `ball_dy_range` about the tray's centre (tray frame); the target
    zone (a visual tile, the tray's outline grown by `zone_margin` on every side, axis-aligned) has its centre
    uniform in x in `zone_x_range`, y in `zone_y_range` (a 25-36 cm carry).

    **Success:** the tray was carried by both arms: at some control step each gripper held it (`ee.holds` for
    the left and the right) while its bottom was at least `lift_height` above the table and it was tilted by
    less than `max_tilt` (the LiftTwoHanded family's lift, `LiftTwoHandedTask`; episode memory `carried`), and
    at no control step was its bottom more than `rest_tol` above the table without both grippers holding it
    (episode memory `one_handed`: no throw, no one-armed carry or drop); the ball has never left the tray (its
    centre within the tray's inner rectangle and at most the rim's height plus `ball_radius` above the tray
    floor, on every control step; episode memory `dropped`); and now the tray rests on the table (its bottom
    within `rest_tol` of the table) with its four corners inside the target zone (the tray's outline grown by
    `zone_margin` on every side), neither gripper holds it, and the ball lies on the tray.

    **Level 2:** (against Level 1's LiftWideBox, the same two-gripper lift: 2 stages, grasp and lift, 47 steps
    mean, 15 degrees of tilt allowed): 4 stages, ~130 steps mean (grasp both end walls, lift, carry 25-36 cm,
    set down and release), with a free 2.7 g ball rolling on the tray floor behind a lip only 4 mm high (the
    12 mm rims less the 8 mm floor): the ball rolls the tray's whole 20 cm depth from rim to rim as the carry
    starts and stops, and a carry whose targets advance 2 cm a control step (seeds 100-103) throws it over the
    front lip at the stop on 4 of 4 seeds (1.5 cm: 0 of 4; the solver carries at 0.6 cm), so both arms must
    move in lock-step and gently; the tray must end inside a zone only 3 cm wider than it on every side.
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 10
    TASK_REGION = (-0.4, 0.3, -0.3, 0.3)
    PARAMS = LiftTwoHandedTask.PARAMS + ("zone_margin", "rest_tol", "rim_height", "ball_radius", "ball_mass",
                                         "tray_x_range", "tray_y_range", "tray_max_yaw", "ball_dx_range",
                                         "ball_dy_range", "zone_x_range", "zone_y_range")
    # layout ranges as (low, span)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.tray = build_serving_tray(self.scene, "tray", TRAY_INNER_HALF, self.rim_height, TRAY_END_HEIGHT,
                                       TRAY_WALL, TRAY_BASE, color=(0.55, 0.35, 0.2, 1))
        self.ball = build_ping_pong_ball(self.scene, "ball", self.ball_radius, self.ball_mass,
                                         color=(0.95, 0.5, 0.1, 1))
        zone_half = tuple(h + self.zone_margin for h in self.tray_outer_half)
        self.zone = build_zone_marker(self.scene, "target_zone", zone_half, (0.3, 0.65, 0.35, 1))
        self.item = self.tray
        self.memory.flag("carried")  # lifted level by both grippers
        self.memory.flag("one_handed")  # off the table while not held by both grippers
        self.memory.flag("dropped")  # the ball has left the tray

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            tray = torch.stack([uniform(b, self.tray_x_range), uniform(b, self.tray_y_range), torch.zeros(b)], dim=1)
            tray_q = yaw_quat((torch.rand(b) * 2 - 1) * np.deg2rad(self.tray_max_yaw))
            self.tray.set_pose(Pose.create_from_pq(tray, tray_q))
            local = torch.stack([uniform(b, self.ball_dx_range), uniform(b, self.ball_dy_range),
                                 torch.full((b,), TRAY_BASE + self.ball_radius)], dim=1)
            place_at_rest(self.ball, Pose.create_from_pq(tray + quaternion_apply(tray_q, local)))
            zone = torch.stack([uniform(b, self.zone_x_range), uniform(b, self.zone_y_range), torch.zeros(b)], dim=1)
            zone[:, 2] = MARKER_THICKNESS / 2
            self.zone.set_pose(Pose.create_from_pq(zone))

    @property
    def tray_outer_half(self) -> tuple[float, float]:
        return tuple(h + TRAY_WALL for h in TRAY_INNER_HALF)

    def ball_on_tray(self) -> torch.Tensor:
        """(num_envs,) bool: the ball's centre lies within the tray's inner rectangle and at most the rim's
        height plus the ball's radius above the tray floor (tray frame)."""
        tray = self.tray.pose  # closed form (Pose.inv() * Pose costs ~4x as much, twice a step)
        local = quaternion_apply(quaternion_invert(tray.q), self.ball.pose.p - tray.p)
        inside = (local[:, 0].abs() <= TRAY_INNER_HALF[0]) & (local[:, 1].abs() <= TRAY_INNER_HALF[1])
        low = (local[:, 2] >= TRAY_BASE) & (local[:, 2] <= TRAY_BASE + self.rim_height + self.ball_radius)
        return inside & low

    def tray_corners(self) -> torch.Tensor:
        """(num_envs, 4, 3) world positions of the tray's four outer bottom corners."""
        hx, hy = self.tray_outer_half
        local = torch.tensor([[sx * hx, sy * hy, 0.0] for sx in (1, -1) for sy in (1, -1)], device=self.device)
        q = self.tray.pose.q[:, None].expand(-1, 4, -1)
        return self.tray.pose.p[:, None] + quaternion_apply(q, local[None].expand(self.num_envs, -1, -1))

    def _update_memory(self):
        self.memory.latch("dropped", ~self.ball_on_tray())
        # the holds (a contact pass each) only where the tray is off the table and not yet known to have been
        # carried and never held by fewer than both grippers while off the table
        off = self.tray.pose.p[:, 2] > self.rest_tol
        todo = off & ~(self.memory["carried"] & self.memory["one_handed"])
        if bool(todo.any()):
            both = self.ee.holds(self.tray, "left") & self.ee.holds(self.tray, "right")
            self.memory.latch("one_handed", off & ~both)
            up = (self.tray.pose.p[:, 2] >= self.lift_height) & (tilt(self.tray) < np.deg2rad(self.max_tilt))
            self.memory.latch("carried", up & both)

    def wall_points(self) -> dict[str, torch.Tensor]:
        """World grasp points on the two end walls (mid-thickness, 2 cm below the top), keyed by the arm that
        takes them."""
        y = TRAY_INNER_HALF[1] + TRAY_WALL / 2
        return {side: (self.tray.pose * Pose.create_from_pq(torch.tensor(
            [[0.0, sign * y, TRAY_END_HEIGHT - 0.02]], device=self.device))).p for side, sign in SIDE_SIGNS.items()}

    def _get_obs_extra(self, info: dict):
        return self.two_hand_obs(info, self.wall_points(), "wall", dict(
            tray_pose=self.tray.pose.raw_pose, ball_pos=self.ball.pose.p, ball_vel=self.ball.linear_velocity,
            zone_pos=self.zone.pose.p, tray_to_zone=self.zone.pose.p - self.tray.pose.p))

    def evaluate(self):
        info = LiftTwoHandedTask.evaluate(self)  # the lift: height, tilt, each gripper's hold
        rel = self.tray_corners() - self.zone.pose.p[:, None]
        zx, zy = (h + self.zone_margin for h in self.tray_outer_half)
        info["in_zone"] = ((rel[..., 0].abs() <= zx) & (rel[..., 1].abs() <= zy)).all(dim=1)
        info["on_table"] = self.tray.pose.p[:, 2] <= self.rest_tol
        info["ball_on_tray"] = self.ball_on_tray()
        info["released"] = ~(info["left_grasped"] | info["right_grasped"])
        for name in ("carried", "one_handed", "dropped"):
            info[name] = self.memory[name]
        info["success"] = (info["carried"] & ~info["one_handed"] & ~info["dropped"] & info["ball_on_tray"]
                           & info["in_zone"] & info["on_table"] & info["released"])
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach and hold both end walls; lift level with both (kept once carried); then over the zone, down and
        # let go, all of it only while the ball is on the tray and the tray has never been aloft in fewer hands
        reward = self.reach_and_hold_reward(self.wall_points(), info)
        both = info["left_grasped"] & info["right_grasped"]
        lift = (info["height"] / self.lift_height).clamp(0, 1) * info["is_level"]
        reward += 2 * torch.where(info["carried"], 1.0, both * lift)
        gap = torch.linalg.norm((self.zone.pose.p - self.tray.pose.p)[:, :2], dim=1)
        placed = info["in_zone"] & info["on_table"]
        reward += info["carried"] * (3 * (1 - torch.tanh(5 * gap)) + 2 * placed + info["released"] * placed)
        reward *= (info["ball_on_tray"] & ~info["dropped"] & ~info["one_handed"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
