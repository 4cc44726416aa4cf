"""MoldClayHand (L3 deformable SX): press a lump of clay into a square mould with the LEAP hand until it fills it."""

from __future__ import annotations

from typing import Any

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import clay
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import symmetric_deg, uniform
from maniladder_ms.tasks.clay.base import ClayTask

MOULD_WALL = 0.01  # m: wall thickness of the mould
MOULD_COLOR = (0.55, 0.38, 0.22, 1)  # wood
HAND_NEAR = 0.15  # m: contacts are asked only with the palm this close to the mould's centre (else: not touching)


@register_task("MoldClayHand")
class MoldClayHandEnv(ClayTask, ManiLadderEnv):
    """**Task:** a square mould (an open frame of four walls fixed on the table, no floor) holds a lump of clay
    (plastic: it keeps the shape it is pressed into) standing in its middle, three times as tall as the walls; press
    the clay down into the mould with the LEAP hand until it covers the mould's floor out into the corners.

    **Randomisation:** the mould (inside 2 `mould_half` square, walls `mould_depth` high and 1 cm thick) stands
    with its centre uniform in x in `mould_x_range`, y in `mould_y_range`, turned by a yaw uniform in
    +-`mould_max_yaw`; the clay (particles on a 1.2 cm lattice within +-`clay_half`: a block of 3 x 3 x 3
    particles, 3.6 cm a side) stands on the table inside it, its centre offset from the mould's by up to
    `clay_max_offset` along each of the mould's axes (uniform), turned against the mould by a yaw uniform in
    +-`clay_max_yaw`.

    **Success:** the mould is filled: its inside is divided into `mould_cells` x `mould_cells` square columns,
    and a column is filled when a clay particle's centre lies in it no higher than the walls' top (`clay.Mould`,
    `clay.mould_fill`: clay on the rim, outside the walls or stacked above the rim fills nothing); at least
    `min_fill` of the columns are filled now; and the hand pressed it in: at some step that many columns were
    filled while the hand touched the clay (`ee.touches`) or at most `settle_steps` control steps after it last
    touched it (the pressed clay settles for a few steps once the palm comes off; episode memory `touched`,
    `untouched_steps`, `pressed_in`).

    **Level 3:** against Level 1's PokeClayHand (one fingertip poke 1 cm deep anywhere within 1 cm of a point,
    ~60 steps) and Level 2's clay tasks (PressClayFlat: any shape 50% lower and 1.5x wider, strokes at the highest
    point; StampClay: one level press of a held tool, IoU 0.5, ~120 steps), the clay must take a spatial target
    with corners: 13 of the 16 columns (1.35 cm square) of a 5.4 cm mould, from a 3.6 cm lump that stands over 4-9
    of them; only the bottom layer counts (walls 1.2 cm high: a particle resting on others stands above the rim),
    and a corner column holds a particle centre only within a 7.7 mm square (between the column's inner edges and a
    particle radius off both walls). The 27 particles are more than a single layer under the rim holds (~20-23),
    so the lump must be pressed level into the mould: a palm 5 degrees off level (1.3 cm across its diagonal)
    squeezes the clay to its high side and leaves the row of columns on the low side empty, and one press straight
    down to the rim left the row farthest from the lump's middle empty on 1 seed in 10; the scripted hand presses
    twice (halfway, then onto the rim), its palm aimed tilted against the arm's give and re-centred every step.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.25, 0.02, -0.15, 0.15)
    PARAMS = ("mould_half", "mould_depth", "mould_cells", "min_fill", "settle_steps", "clay_half", "mould_x_range",
              "mould_y_range", "mould_max_yaw", "clay_max_offset", "clay_max_yaw")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_block(self.clay_half, self.clay_config.spacing))
        self.mould = clay.Mould(self.scene, "mould", self.mould_half, self.mould_depth, MOULD_WALL, self.mould_cells,
                                MOULD_COLOR)
        self.palm = self.ee["main"].link("leap_palm")
        self.memory.flag("touched")  # the hand has touched the clay
        self.memory.counter("untouched_steps")  # control steps since the hand last touched the clay
        self.memory.flag("pressed_in")  # the mould was filled while the hand touched the clay or just after

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            centre = torch.stack([uniform(b, self.mould_x_range), uniform(b, self.mould_y_range), torch.zeros(b)], dim=1)
            yaw = symmetric_deg(b, self.mould_max_yaw)
            self.mould.set_pose(Pose.create_from_pq(centre, yaw_quat(yaw)))
            span = (-self.clay_max_offset, self.clay_max_offset)
            offset = torch.stack([uniform(b, span), uniform(b, span)], dim=1)  # in the mould's axes
            c, s = torch.cos(yaw), torch.sin(yaw)
            world = torch.stack([c * offset[:, 0] - s * offset[:, 1], s * offset[:, 0] + c * offset[:, 1]], dim=1)
            origin = torch.cat([centre[:, :2] + world, torch.full((b, 1), self.clay_config.radius)], dim=1)
            self.clay.reset(env_idx, origin, yaw=yaw + symmetric_deg(b, self.clay_max_yaw))

    def fill(self) -> torch.Tensor:
        """Share of the mould's columns holding clay below its rim, [B]."""
        return self.mould.fill(self.clay.positions())

    def _update_memory(self):
        near = torch.linalg.norm(self.palm.pose.p[:, :2] - self.mould.pose.p[:, :2], dim=1) <= HAND_NEAR
        touching = torch.zeros_like(near)
        if bool(near.any()):  # the contact pass (over every particle on the CPU) only with the hand over the mould
            touching = near & self.ee.touches(self.clay.spheres)
        self.memory.latch("touched", touching)
        self.memory.count("untouched_steps", ~touching, consecutive=True)
        recent = self.memory["touched"] & (self.memory["untouched_steps"] <= self.settle_steps)
        self.memory.latch("pressed_in", recent & (self.fill() >= self.min_fill))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(mould_pose=self.mould.pose.raw_pose, clay_points=self.clay.positions().flatten(1),
                       fill=info["fill"])
        return obs

    def evaluate(self):
        fill, pressed_in = self.fill(), self.memory["pressed_in"]
        return {"success": (fill >= self.min_fill) & pressed_in, "fill": fill, "is_filled": fill >= self.min_fill,
                "pressed_in": pressed_in}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        top = self.clay.positions().mean(dim=1)
        top[:, 2] = self.clay.positions()[..., 2].amax(dim=1)
        reach = 1 - torch.tanh(5 * torch.linalg.norm(top - self.ee.tcp().p, dim=1))
        reward = reach + 3 * (info["fill"] / self.min_fill).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
