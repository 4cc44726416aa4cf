"""PokeClayHand (L1 deformable SX): make a dent in a clay block with the LEAP hand's index finger."""

from __future__ import annotations

from typing import Any

import torch

from maniladder_ms.agents.effectors import TOUCH_FORCE, link_forces
from maniladder_ms.agents.effectors import leap_fingertip
from maniladder_ms.deformables import clay
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.tasks.clay.base import ClayTask


@register_task("PokeClayHand")
class PokeClayHandEnv(ClayTask, ManiLadderEnv):
    """**Task:** a block of clay (plastic: it keeps the shape it is pressed into) lies on the table; poke
    a dent at least 1 cm deep into the middle of its top with the LEAP hand's index finger.

    **Randomisation:** the block (particle centres within +-`block_half`: 5 x 5 x 3 particles on a 1.2 cm
    lattice, 6 x 6 x 3.6 cm) is scaled by a factor uniform in `clay_scale_range` (`Clay.reset`), turned by a
    yaw uniform in `clay_yaw_range`, its centre uniform in x in `clay_x_range`, y in `clay_y_range`.

    **Success:** the dent at the block's top centre (the start's, a fixed table point) is >= `min_depth`
    deep: `clay.dent_depth`, the start's top there minus the current top of the clay within
    `dent_radius` of that point (the highest particle top there: every particle near the point must have
    been pushed down); and the index finger made it: at some step the dent was that deep while the index
    finger's tip or middle link touched the clay (episode memory `poked`).
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 4
    TASK_REGION = (-0.25, 0.0, -0.2, 0.2)
    PARAMS = ("block_half", "min_depth", "dent_radius") + ClayTask.CLAY_LAYOUT_PARAMS
    INDEX_LINKS = ("leap_index_dip", "leap_index_tip")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_block(self.block_half, self.clay_config.spacing))
        self.index_links = [self.ee["main"].link(name) for name in self.INDEX_LINKS]
        self.memory.flag("poked")

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self.reset_clay(env_idx)

    def dent_point(self) -> torch.Tensor:
        """The start's top centre of the block, [B, 3]: where the dent goes."""
        start = self.clay.start
        point = start.mean(dim=1)
        point[:, 2] = start[..., 2].amax(dim=1) + self.clay_config.radius
        return point

    def _depth(self) -> torch.Tensor:
        point, r = self.dent_point(), self.clay_config.radius
        return clay.dent_depth(self.clay.positions(), point[:, :2], point[:, 2], self.dent_radius, r)

    def index_touches(self) -> torch.Tensor:
        """The index finger (`INDEX_LINKS`) presses on a clay particle, [B]. (Local: the vocabulary's
        `touches` asks about the whole hand.)"""
        touching = [(link_forces(self.scene, particle, self.index_links) >= TOUCH_FORCE).any(dim=0)
                    for particle in self.clay.spheres]
        return torch.stack(touching).any(dim=0)

    def _update_memory(self):
        deep = self._depth() >= self.min_depth
        if bool(deep.any()):  # the contact query (one pass per particle on the CPU) only when it can matter
            self.memory.latch("poked", deep & self.index_touches())

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(clay_points=self.clay.positions().flatten(1), dent_depth=info["dent_depth"],
                       fingertip_to_dent=self.dent_point() - leap_fingertip(self.agent))
        return obs

    def evaluate(self):
        depth, poked = self._depth(), self.memory["poked"]
        return {"success": (depth >= self.min_depth) & poked, "dent_depth": depth, "poked": poked}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.dent_point() - leap_fingertip(self.agent), dim=1))
        dent = (info["dent_depth"] / self.min_depth).clamp(0, 1)
        reward = reach + 2 * dent
        reward[info["success"]] = self.max_dense_reward
        return reward
