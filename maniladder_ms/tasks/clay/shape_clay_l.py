"""ShapeClayL (L3 deformable SG): shape a square clay slab into the L marked on the table with the gripper."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import clay
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.markers import MARKER_THICKNESS
from maniladder_ms.tasks.clay.base import ClayTask

SLAB_SITES = 8  # lattice sites along each side of the slab (even: the L's quarter ends between two of them)
SLAB_LAYERS = 2  # lattice layers of the slab
L_COLOR = (0.55, 0.8, 0.55, 1)  # the L marked on the table
OUTLINE_COLOR = (0.15, 0.35, 0.15, 1)  # its outline
OUTLINE_WIDTH = 0.004  # m: the outline's strips, just outside the L
NEAR_CLAY = 0.1  # m: contacts are asked only with the TCP this close to the L's centre (else: not touching)


def slab_layout(sites: int, layers: int, spacing: float) -> np.ndarray:
    """Rest positions [N, 3] of a slab of `sites` x `sites` x `layers` lattice points centred on the z axis,
    lowest particle centres at z = 0."""
    side = (np.arange(sites) - (sites - 1) / 2) * spacing
    up = np.arange(layers) * spacing
    return np.stack(np.meshgrid(side, side, up, indexing="ij"), axis=-1).reshape(-1, 3)


def l_outline_boxes(half: float, width: float) -> list[tuple[list[float], list[float]]]:
    """(centre, half size) of thin strips just outside the outline of the L that is the square of side 2 `half`
    round the origin without its +x +y quarter: six strips `width` wide, in the L's frame."""
    h, w = half, width / 2
    return [
        ([0.0, -h - w, 0.0], [h + width, w, 0.0]),  # the long edge along -y
        ([-h - w, 0.0, 0.0], [w, h + width, 0.0]),  # the long edge along -x
        ([h / 2, w, 0.0], [h / 2 + w, w, 0.0]),  # the -x arm's end... the +x arm's top edge (y = 0)
        ([h + w, -h / 2, 0.0], [w, h / 2 + width, 0.0]),  # the +x arm's end
        ([w, h / 2, 0.0], [w, h / 2 + w, 0.0]),  # the +y arm's inner edge (x = 0)
        ([-h / 2, h + w, 0.0], [h / 2 + width, w, 0.0]),  # the +y arm's end
    ]


def build_l_marker(scene, name: str, half: float):
    """The L marked on the table (visual only, kinematic): the square of side 2 `half` round its origin without
    its +x +y quarter, filled, with a dark outline just outside it."""
    builder = scene.create_actor_builder()
    if scene.can_render():
        fill = sapien.render.RenderMaterial(base_color=list(L_COLOR), roughness=0.9)
        line = sapien.render.RenderMaterial(base_color=list(OUTLINE_COLOR), roughness=0.9)
        z = MARKER_THICKNESS / 2
        for centre, size in (([0.0, -half / 2, 0.0], [half, half / 2, z]), ([-half / 2, half / 2, 0.0], [half / 2, half / 2, z])):
            builder.add_box_visual(sapien.Pose(p=centre), half_size=size, material=fill)
        for centre, size in l_outline_boxes(half, OUTLINE_WIDTH):
            builder.add_box_visual(sapien.Pose(p=centre), half_size=[size[0], size[1], z], material=line)
    builder.initial_pose = sapien.Pose(p=[0, 0, MARKER_THICKNESS / 2])
    return builder.build_kinematic(name=name)


@register_task("ShapeClayL")
class ShapeClayLEnv(ClayTask, ManiLadderEnv):
    """**Task:** a square slab of clay (plastic: it keeps the shape it is pressed into) lies on the table over an
    L marked there: the slab's own square without one quarter. Shape the slab into the L with the gripper: clear the
    clay out of the missing quarter without leaving the L's arms bare or spreading clay round the L.

    **Randomisation:** the L (the square of the slab, 9.6 cm a side, without its quarter on the L's +x, +y side) has
    its centre uniform in x in `target_x_range`, y in `target_y_range`, turned by a yaw uniform in
    `target_yaw_range` (deg: a full turn, so the missing quarter lies on any side of the robot); the slab (particles
    on a 1.2 cm lattice, 8 x 8 x 2 of them) lies on the L's square with the L's yaw.

    **Success:** the table round the L is read as a grid of `grid_cells` x `grid_cells` square columns one lattice
    spacing wide, centred on and turned with the L, the L's square `grid_cells` less eight cells... in from each
    edge; a column is occupied when a clay particle's centre lies in it at most `on_table_height` above the table
    (`clay.cells_occupied`: clay held up in the air occupies nothing); the occupied columns and the L's have an
    intersection over union of at least `min_iou` (`clay.occupancy_iou`, `clay.l_footprint`); the gripper shaped it
    (it touched the clay at some step, episode memory `touched`); and the gripper is off the clay (the shape holds by
    itself).
    """

    max_dense_reward = 5
    TASK_REGION = (-0.2, 0.12, -0.2, 0.2)
    PARAMS = ("grid_cells", "min_iou", "on_table_height", "target_x_range", "target_y_range", "target_yaw_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        spacing = self.clay_config.spacing
        self.load_clay(slab_layout(SLAB_SITES, SLAB_LAYERS, spacing))
        self.l_half = SLAB_SITES * spacing / 2
        self.grid_half = self.grid_cells * spacing / 2
        self.l_cells = clay.l_footprint(self.grid_cells, (self.grid_cells - SLAB_SITES) // 2).to(self.device)
        self.marker = build_l_marker(self.scene, "l_marker", self.l_half)
        self.memory.flag("touched")  # the gripper has touched the clay

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            centre = torch.stack([uniform(b, self.target_x_range), uniform(b, self.target_y_range),
                                  torch.full((b,), MARKER_THICKNESS / 2)], dim=1)
            yaw = uniform_deg(b, self.target_yaw_range)
            self.marker.set_pose(Pose.create_from_pq(centre, yaw_quat(yaw)))
            origin = centre.clone()
            origin[:, 2] = self.clay_config.radius
            self.clay.reset(env_idx, origin, yaw=yaw)

    def l_centre(self) -> torch.Tensor:
        """The L's square's centre on the table, [B, 3] (z = 0)."""
        return self.marker.pose.p * torch.tensor([1.0, 1.0, 0.0], device=self.device)

    def l_yaw(self) -> torch.Tensor:
        """The L's yaw (its missing quarter on its own +x, +y side), [B]."""
        from maniladder_ms.geometry import yaw_of
        return yaw_of(self.marker.pose.q)

    def occupied(self) -> torch.Tensor:
        """The grid's columns holding clay, [B, grid_cells, grid_cells]."""
        return clay.cells_occupied(self.clay.positions(), self.l_centre(), self.l_yaw(), self.grid_half,
                                   self.on_table_height, self.grid_cells)

    def _update_memory(self):
        near = torch.linalg.norm(self.ee.tcp().p[:, :2] - self.l_centre()[:, :2], dim=1) <= NEAR_CLAY
        if bool((near & ~self.memory["touched"]).any()):  # the contact pass only where it can change the flag
            self.memory.latch("touched", near & self.ee.touches(self.clay.spheres))

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs.update(l_pose=self.marker.pose.raw_pose, clay_points=self.clay.positions().flatten(1), iou=info["iou"])
        return obs

    def evaluate(self):
        occupied = self.occupied()
        iou = clay.metrics.iou(occupied, self.l_cells)
        quarter = occupied & ~self.l_cells  # occupied columns outside the L
        shaped = (iou >= self.min_iou) & self.memory["touched"]
        released = torch.ones_like(shaped)
        if bool(shaped.any()):  # the contact pass only where it can decide success
            released = ~self.ee.touches(self.clay.spheres)
        return {"success": shaped & released, "iou": iou, "is_shaped": iou >= self.min_iou,
                "touched": self.memory["touched"], "cells_outside": quarter.flatten(1).sum(dim=1),
                "cells_bare": (self.l_cells & ~occupied).flatten(1).sum(dim=1)}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.l_centre() - self.ee.tcp().p, dim=1))
        reward = reach + 3 * ((info["iou"] - 0.75).clamp_min(0) / (self.min_iou - 0.75)).clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
