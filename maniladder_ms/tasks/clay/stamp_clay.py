"""StampClay (L2 deformable SG): grasp a star-shaped stamp by its handle and press its imprint into a clay slab."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import TOUCH_FORCE, pair_forces
from maniladder_ms.deformables import clay
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_of, yaw_quat
from maniladder_ms.layout import uniform
from maniladder_ms.objects.tabletop import place_at_rest
from maniladder_ms.objects.tools import StarStampShape, build_star_stamp
from maniladder_ms.tasks.clay.base import ClayTask

STAMP_DENSITY = 600.0  # kg/m^3 (a wooden stamp)
STAMP_COLOR = (0.55, 0.35, 0.18, 1)
NO_PRESS = 1.0  # memory "press" height before any press (above everything)
PRESS_QUERY_ABOVE = 0.01  # contact queries only with the plate within this of the slab's top


@register_task("StampClay")
class StampClayEnv(ClayTask, ManiLadderEnv):
    """**Task:** a slab of clay (plastic: it keeps the shape it is pressed into) lies on the table; a stamp, a
    star-shaped plate with a square post on top as its handle, stands beside it. Grasp the stamp by its
    handle, hold it over the middle of the slab, press the star straight down into the clay and lift it off,
    leaving a star-shaped imprint.

    **Randomisation:** the slab (particles on a 1.2 cm lattice within `slab_half`: 9 x 9 x 3 of them,
    10.8 x 10.8 x 3.6 cm, spheres included; scaled by a factor uniform in `clay_scale_range`: not scaled) is
    turned by a yaw uniform in `clay_yaw_range`, its centre uniform in x in `clay_x_range`, y in `clay_y_range`;
    the stamp (5 arms, tips at radius `outer`, valleys at `inner`, a 1.2 cm plate, a 2 cm post 7 cm high) stands
    upright to the robot's right, its centre uniform in x in `stamp_x_range`, y in `stamp_y_range`, turned by a
    uniform yaw in [0, 2 pi / 5) (all the star's yaws: a full turn over its arms).

    **Success:** the stamp was pressed into the clay while the gripper held it (at some step the held stamp
    touched the clay, `ee.holds`; episode memory `held_press`, and its pose at the lowest such step,
    `press`: the press pose); the press pose's centre lies within `max_offset` of the slab's start centre
    (the star lies on the slab); the imprint matches the star: of the slab's top layer, the cells that sank
    at least `min_depth` below their start height and the cells under the star's outline at the press pose
    (`clay.imprint_iou`, cells tested at their start xy) have an intersection over union of at least
    `min_iou`; and the stamp is lifted off (it does not touch the clay).

    **Level 2:** against Level 1's PressClayFlat (one stage: press the closed gripper into a clay ball,
    ~120 steps, any flat enough shape counts): 4 stages in ~120 steps (grasp the 2 cm post, carry the stamp
    over the slab, press it level, lift it off), the press centred within 1 cm on a 10.8 cm slab with a
    10 cm star; the clay must take the tool's shape: of the 81 top cells, the star's 25-30 and few others
    at least 5 mm deep (IoU >= 0.5; the scripted press reaches 0.64-0.77), so the stamp goes down level and
    about 8 mm deep (+-2 mm: 1.5 mm shallower leaves the star's cells short of 5 mm, 3 mm deeper drags the
    cells along its outline down with them), and comes straight up (a slide smears the imprint).
    """

    max_dense_reward = 6
    TASK_REGION = (-0.17, 0.13, -0.26, 0.14)
    PARAMS = ("outer", "inner", "slab_half", "min_depth", "min_iou", "max_offset", "stamp_x_range",
              "stamp_y_range") + ClayTask.CLAY_LAYOUT_PARAMS

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_block(self.slab_half, self.clay_config.spacing))
        self.stamp_shape = StarStampShape(self.outer, self.inner)
        self.stamp = build_star_stamp(self.scene, "stamp", self.stamp_shape, STAMP_DENSITY, color=STAMP_COLOR)
        self.memory.flag("held_press")  # the held stamp touched the clay
        self.memory.value("press", 4, NO_PRESS)  # x, y, yaw, height of the stamp at the lowest held press

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self.reset_clay(env_idx)
            b = len(env_idx)
            p = torch.stack([uniform(b, self.stamp_x_range), uniform(b, self.stamp_y_range), torch.zeros(b)], dim=1)
            yaw = torch.rand(b) * 2 * np.pi / self.stamp_shape.arms
            place_at_rest(self.stamp, Pose.create_from_pq(p, yaw_quat(yaw)))

    def slab_centre(self) -> torch.Tensor:
        """The slab's start centre on the table, [B, 2]."""
        return self.clay.start[..., :2].mean(dim=1)

    def slab_top(self) -> torch.Tensor:
        """Height of the slab's top surface at the start, [B]."""
        return self.clay.start[..., 2].amax(dim=1) + self.clay_config.radius

    def stamp_touches_clay(self) -> torch.Tensor:
        """The stamp presses on some clay particle, [B] (one pass over the contacts)."""
        forces = pair_forces(self.scene, self.clay.spheres, [self.stamp]).norm(dim=-1)
        return (forces >= TOUCH_FORCE).any(dim=0).any(dim=0)

    def under_press(self) -> torch.Tensor:
        """The clay particles whose start xy lies under the star's outline at the press pose, [B, N]."""
        press = self.memory["press"]
        rel = self.clay.start[..., :2] - press[:, None, :2]
        c, s = torch.cos(press[:, 2:3]), torch.sin(press[:, 2:3])
        local = torch.stack([c * rel[..., 0] + s * rel[..., 1], -s * rel[..., 0] + c * rel[..., 1]], dim=-1)
        return self.stamp_shape.contains(local)

    def _update_memory(self):
        z = self.stamp.pose.p[:, 2]
        # contact queries only where the plate is near the clay's top and lower than before
        lower = (z < self.memory["press"][:, 3]) & (z < self.slab_top() + PRESS_QUERY_ABOVE)
        if bool(lower.any()):
            pressing = lower & self.ee.holds(self.stamp) & self.stamp_touches_clay()
            if bool(pressing.any()):
                self.memory.latch("held_press", pressing)
                pose = torch.cat([self.stamp.pose.p[:, :2], yaw_of(self.stamp.pose.q)[:, None], z[:, None]], dim=1)
                self.memory.store("press", torch.where(pressing[:, None], pose, self.memory["press"]))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(stamp_pose=self.stamp.pose.raw_pose, clay_points=self.clay.positions().flatten(1),
                       slab_centre=self.slab_centre(), imprint_iou=info["imprint_iou"])
        return obs

    def evaluate(self):
        held_press = self.memory["held_press"]
        iou = clay.imprint_iou(self.clay.start, self.clay.positions(), self.under_press(), self.min_depth,
                               self.clay_config.spacing)
        offset = torch.linalg.norm(self.memory["press"][:, :2] - self.slab_centre(), dim=1)
        imprinted = held_press & (iou >= self.min_iou) & (offset <= self.max_offset)
        lifted = torch.ones_like(imprinted)
        if bool(imprinted.any()):  # the contact pass only where it can decide success
            lifted = ~self.stamp_touches_clay()
        return {
            "success": imprinted & lifted,
            "held_press": held_press,
            "imprinted": imprinted,
            "imprint_iou": iou * held_press,
            "press_offset": offset,
            "stamp_grasped": self.ee.holds(self.stamp),
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        handle = self.stamp.pose.p.clone()
        handle[:, 2] += self.stamp_shape.plate + self.stamp_shape.handle_height / 2
        reward = 1 - torch.tanh(5 * torch.linalg.norm(handle - self.ee.tcp().p, dim=1))
        held = info["stamp_grasped"].float()
        over = torch.linalg.norm(self.stamp.pose.p[:, :2] - self.slab_centre(), dim=1)
        reward += held * (1 + (1 - torch.tanh(10 * over)))
        reward += 2 * (info["imprint_iou"] / self.min_iou).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
