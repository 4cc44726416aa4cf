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
from maniladder_ms.geometry import yaw_of, yaw_quat
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
    """(centre, half size) of thin strips `width` wide just outside the outline of the L that is the square of side
    2 `half` round the origin without its +x +y quarter, in the L's frame: its six edges."""
    h, w = half, width / 2
    return [
        ([0.0, -h - w, 0.0], [h + width, w, 0.0]),  # the long edge at y = -half
        ([-h - w, 0.0, 0.0], [w, h + width, 0.0]),  # the long edge at x = -half
        ([h + w, -h / 2, 0.0], [w, h / 2 + width, 0.0]),  # the end of the arm along +x
        ([h / 2, w, 0.0], [h / 2 + w, w, 0.0]),  # that arm's inner edge (y = 0), on the quarter's side
        ([w, h / 2, 0.0], [w, h / 2 + w, 0.0]),  # the inner edge (x = 0) of the arm along +y
        ([-h / 2, h + w, 0.0], [h / 2 + width, w, 0.0]),  # the end of the arm along +y
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
    L marked there (filled, with a dark outline): the slab's own square without one quarter. Shape the slab into the
    L with the gripper: clear the clay out of the missing quarter without dragging the L's arms off their marks or
    leaving clay round the L.

    **Randomisation:** the L (the slab's square, 9.6 cm a side, without its quarter on the L's own +x, +y side) has
    its centre uniform in x in `target_x_range`, y in `target_y_range`, turned by a yaw uniform in
    `target_yaw_range` (deg: a full turn, so the missing quarter lies on any side as seen from the robot); the slab
    (particles on a 1.2 cm lattice, 8 x 8 x 2 of them, 128 in all) lies exactly on the L's square, with its yaw.

    **Success:** the table round the L is read as a grid of `grid_cells` x `grid_cells` square columns one lattice
    spacing wide, centred on the L's square and turned with it (the square's columns in its middle); a column is
    occupied when a clay particle's centre lies in it at most `on_table_height` above the table (`clay.cells_occupied`:
    clay held up in the air occupies nothing, clay pushed past the grid counts for nothing); the occupied columns and
    the L's columns (`clay.l_footprint`) have an intersection over union of at least `min_iou`
    (`clay.occupancy_iou`; the untouched slab scores three quarters); the gripper shaped it (it touched the clay at
    some step: episode memory `touched`); and the gripper is off the clay (the shape holds by itself).

    **Level 3:** against Level 2's clay tasks (StampClay: one held press, IoU >= 0.5 of a 10 cm star's imprint on a
    10.8 cm slab, ~120 steps; FlattenClayWithRoller: any shape half as high and wider), the clay must take a spatial
    target with a concave corner on a grid of 1.2 cm columns: from IoU 0.75 at the start to >= 0.85, i.e. of the
    quarter's 16 columns at most ~8 left occupied with the L's 48 all kept, or fewer with any arm column bared or any
    column round the L occupied. The closed fingertips (a blade ~2 cm wide) need 4-8 strokes (mean 6, ~150-470
    steps) through a 4.8 cm quarter, the later ones each aimed at the clay the last left behind; the links between the
    quarter and the arms drag the arms along a stroke (a stroke started on an arm's side dragged it off its columns:
    IoU 0.87 -> 0.72 after two such strokes), so every stroke starts inside the quarter, >= 1.2 cm off both arms, and
    runs away from them, its blade sinking into the clay on a ramp (landing straight down squeezed the arms' outer
    rows off the L).
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
        square = SLAB_SITES**2
        self.start_iou = float(self.l_cells.sum()) / square  # the untouched slab on the L's square
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
        iou = clay.occupancy_iou(self.clay.positions(), self.l_centre(), self.l_yaw(), self.grid_half,
                                 self.on_table_height, self.l_cells)
        occupied = self.occupied()
        shaped = (iou >= self.min_iou) & self.memory["touched"]
        released = torch.ones_like(shaped)
        if bool(shaped.any()):  # the contact pass only where it can decide success
            released = ~self.ee.touches(self.clay.spheres)
        return {"success": shaped & released, "iou": iou, "is_shaped": iou >= self.min_iou,
                "touched": self.memory["touched"], "cells_outside": (occupied & ~self.l_cells).flatten(1).sum(dim=1),
                "cells_bare": (self.l_cells & ~occupied).flatten(1).sum(dim=1)}

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        reach = 1 - torch.tanh(5 * torch.linalg.norm(self.l_centre() - self.ee.tcp().p, dim=1))
        progress = (info["iou"] - self.start_iou).clamp_min(0) / (self.min_iou - self.start_iou)
        reward = reach + 3 * progress.clamp(0, 1)
        reward[info["success"]] = self.max_dense_reward
        return reward
