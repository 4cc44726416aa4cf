"""FlattenClayWithRoller (L2 deformable DG): flatten a lump of clay with a rolling pin held by both arms."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import TOUCH_FORCE, pair_forces
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.tools import RollingPinShape, build_rolling_pin
from maniladder_ms.tasks.clay.flatten_clay.base import FlattenClayTask

SIDES = {"left": 1.0, "right": -1.0}  # the left gripper takes the +y handle
PIN_DENSITY = 700.0  # kg/m^3 (a wooden pin: ~0.2 kg)
PIN_COLOR, PIN_HANDLE_COLOR = (0.85, 0.7, 0.45, 1), (0.5, 0.3, 0.15, 1)
ROLL_AXIS = 0  # the pin lies along world y and rolls along world x
NEAR_CLAY = 0.005  # m: the barrel's bottom within this above the clay's top counts as on it (then contacts are asked)


@register_task("FlattenClayWithRoller")
class FlattenClayWithRollerEnv(FlattenClayTask):
    """**Task:** a ball of clay (plastic: it keeps the shape it is pressed into) lies on the table between
    the two arms; a rolling pin (a barrel with a handle at each end) lies across the table nearer the robot.
    Each arm takes one handle; together they put the pin on the clay and roll it over it, pass by pass,
    until the clay is a flat sheet.

    **Randomisation:** the ball (particles on a 1.2 cm lattice within `ball_radius`: 81 of them, 6 cm
    across, scaled by a factor uniform in `clay_scale_range`: not scaled) is turned by a yaw uniform in
    `clay_yaw_range`, its centre uniform in x in `clay_x_range`, y in `clay_y_range`; the pin (barrel 4 cm across
    and 14 cm long, handles 2.4 cm across and 7 cm long) lies along y, its centre nearer the robot than the
    ball's by a distance uniform in `pin_behind_range` (x), its y uniform in `pin_y_range`.

    **Success:** the clay's height (`clay.height`) is <= `max_height_ratio` of its start height and its
    top-down footprint (`metrics.footprint_area`) >= `min_area_ratio` times its start footprint; and the
    pin was rolled over the clay by both arms: the pin's travel along its rolling direction (world x),
    summed over the control steps in which both grippers held it (`ee.holds` for the left and the right)
    while it touched the clay, is at least `min_roll` (episode memory `rolled`).

    **Level 2:** against Level 1's PressClayFlat (one gripper presses a ball flat, 1 stage, ~120 steps,
    to 50% height and 1.5x footprint): 4 stages (both arms grasp a handle, lift and place the pin on the
    clay together, roll it out from the clay's middle to either end, lowering it each pass), two arms on
    one rigid tool in lock-step (a 1 cm height difference between the grippers tilts the 28 cm pin by 2
    degrees, and the barrel then presses one side of the clay only), to a flatter and wider sheet (40%
    height, 1.8x footprint).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 6
    TASK_REGION = (-0.36, 0.06, -0.22, 0.22)
    PARAMS = ("ball_radius", "max_height_ratio", "min_area_ratio", "min_roll", "pin_behind_range",
              "pin_y_range") + FlattenClayTask.CLAY_LAYOUT_PARAMS
    pin_shape = RollingPinShape()

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.pin = build_rolling_pin(self.scene, "pin", self.pin_shape, PIN_DENSITY, color=PIN_COLOR,
                                     handle_color=PIN_HANDLE_COLOR)
        self.memory.value("rolled")  # the pin's travel along x while both grippers held it on the clay
        self.memory.value("pin_last")  # the pin's x after the previous control step

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)  # the ball, between the arms
        with torch.device(self.device):
            b = len(env_idx)
            centre = self.clay.start[env_idx].mean(dim=1)
            behind_lo, behind_hi = self.pin_behind_range  # drawn as x - low - (high - low) * U
            p = torch.stack([centre[:, 0] - behind_lo - (behind_hi - behind_lo) * torch.rand(b),
                             uniform(b, self.pin_y_range),
                             torch.full((b,), self.pin_shape.barrel_radius)], dim=1)
            self.pin.set_pose(Pose.create_from_pq(p, yaw_quat(torch.zeros(b))))
            self.pin.set_linear_velocity(torch.zeros(b, 3))
            self.pin.set_angular_velocity(torch.zeros(b, 3))
            self.memory.store("pin_last", p[:, :1], env_idx)

    def handle_centres(self) -> dict[str, torch.Tensor]:
        """World centres of the pin's handles, {"left": +y handle, "right": -y handle}, [B, 3] each."""
        pose = self.pin.pose
        return {side: (pose * Pose.create_from_pq(torch.tensor([[0.0, sign * self.pin_shape.handle_offset, 0.0]],
                                                               device=self.device))).p for side, sign in SIDES.items()}

    def pin_touches_clay(self) -> torch.Tensor:
        forces = pair_forces(self.scene, self.clay.spheres, [self.pin]).norm(dim=-1)
        return (forces >= TOUCH_FORCE).any(dim=0).any(dim=0)

    def _update_memory(self):
        x = self.pin.pose.p[:, ROLL_AXIS]
        moved = (x - self.memory["pin_last"][:, 0]).abs()
        bottom = self.pin.pose.p[:, 2] - self.pin_shape.barrel_radius
        near = bottom < self.clay.positions()[..., 2].amax(dim=1) + self.clay_config.radius + NEAR_CLAY
        if bool(near.any()):
            rolling = near & self.ee.holds(self.pin, "left") & self.ee.holds(self.pin, "right")
            if bool(rolling.any()):
                rolling &= self.pin_touches_clay()
                self.memory.store("rolled", self.memory["rolled"] + (moved * rolling)[:, None])
        self.memory.store("pin_last", x[:, None])

    def _get_obs_extra(self, info: dict):
        obs = {f"{side}_tcp_pose": self.ee.tcp(side).raw_pose for side in SIDES}
        if "state" in self.obs_mode:
            obs.update(pin_pose=self.pin.pose.raw_pose, clay_points=self.clay.positions().flatten(1),
                       height_ratio=info["height_ratio"], area_ratio=info["area_ratio"], rolled=info["rolled"])
        return obs

    def evaluate(self):
        shape = self.flatness()
        rolled = self.memory["rolled"][:, 0]
        return {"success": shape["is_flat"] & shape["is_spread"] & (rolled >= self.min_roll), **shape, "rolled": rolled}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reward = torch.zeros(self.num_envs, device=self.device)
        for side, handle in self.handle_centres().items():
            reward += 0.5 * (1 - torch.tanh(5 * torch.linalg.norm(handle - self.ee.tcp(side).p, dim=1)))
        reward += (info["rolled"] / self.min_roll).clamp(0, 1)
        flatten, spread = self.shape_progress(info)
        reward += 2 * flatten
        reward += spread
        reward[info["success"]] = self.max_dense_reward
        return reward
