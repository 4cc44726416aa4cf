"""A low cabinet with one drawer, as a ManiSkill articulation built in code (MobileStoreInCabinet).

The carcass (root link: back, two sides, bottom and top panels) stands on z = 0 with its open front facing -x,
origin at the centre of its footprint. The drawer (child link) is an open-topped box behind a front panel that
covers the carcass' front; a bar handle runs along y in front of the panel on two stems, far enough out for a
gripper's finger to pass between bar and panel. Its prismatic joint slides the drawer out along -x: the joint
value is the opening (0 closed, up to `travel`). Frames: the drawer link's origin is the carcass origin when
closed, its axes the carcass'.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

from .cabinet import add_carcass, add_panel

# prismatic joints slide along their frame's x axis: this half turn about z points it along -x (the drawer opens
# towards the robot)
MINUS_X_AXIS_JOINT = sapien.Pose(q=[0, 0, 0, 1])


@dataclass(frozen=True)
class DrawerCabinetShape:
    """Outer size (depth x, width y, height z) and panel thickness of the carcass; the drawer's front panel
    thickness, the gap round the drawer (to the carcass' panels and between front panel and carcass front), the
    drawer box's wall height and thickness; the handle bar (half length along y, half thickness, stand-off of its
    axis from the front panel's outer face, height of its axis above the floor); the joint's travel, damping and
    friction."""

    depth: float = 0.26
    width: float = 0.3
    height: float = 0.15
    panel: float = 0.012
    front: float = 0.012
    gap: float = 0.003
    wall_height: float = 0.08
    wall: float = 0.008
    bar_half_length: float = 0.06
    bar_half: float = 0.008
    bar_standoff: float = 0.07
    bar_height: float = 0.118
    travel: float = 0.2
    damping: float = 2.0
    friction: float = 0.5

    @property
    def front_face_x(self) -> float:
        """x of the closed drawer's front panel outer face (cabinet frame)."""
        return -self.depth / 2 - self.gap - self.front

    @property
    def box_length(self) -> float:
        """Outer length (x) of the drawer box behind the front panel: it stops short of the back panel."""
        return self.depth - self.panel - 2 * self.gap

    @property
    def floor_z(self) -> float:
        """Height of the drawer's bottom plate's top face above the floor."""
        return self.panel + self.gap + self.wall

    @property
    def inner_half(self) -> tuple[float, float]:
        """Half extents (x, y) of the drawer box's inside."""
        return self.box_length / 2 - self.wall, self.width / 2 - self.panel - self.gap - self.wall

    @property
    def inner_centre_x(self) -> float:
        """x of the drawer box's inside centre, drawer closed (cabinet frame)."""
        return -self.depth / 2 + self.box_length / 2

    def handle_centre(self) -> np.ndarray:
        """Centre of the handle bar, drawer closed (cabinet frame)."""
        return np.array([self.front_face_x - self.bar_standoff, 0.0, self.bar_height])


def build_drawer_cabinet(scene: ManiSkillScene, name: str, shape: DrawerCabinetShape, color, drawer_color,
                         handle_color):
    """The cabinet articulation, its root fixed where `set_pose` puts it (a cabinet does not slide)."""
    builder = scene.create_articulation_builder()
    carcass = add_carcass(builder, name, shape, color, shelf=False)
    d, w, h, t = shape.depth / 2, shape.width / 2, shape.height, shape.panel

    drawer = builder.create_link_builder(carcass)
    drawer.set_name(f"{name}_drawer")
    dmat = sapien.render.RenderMaterial(base_color=list(drawer_color), roughness=0.6)
    hmat = sapien.render.RenderMaterial(base_color=list(handle_color), roughness=0.3, metallic=0.6)
    g, wt = shape.gap, shape.wall
    # front panel: covers the carcass front, `gap` in front of it, its bottom edge level with the carcass' bottom
    # panel's top (clear of the table it slides over)
    add_panel(drawer, [-d - g - shape.front / 2, 0, (h + t) / 2], [shape.front / 2, w - g, (h - t) / 2 - g], dmat)
    # the box behind it: bottom plate, two sides and a back wall, clear of the carcass panels by `gap`
    half_len, half_w = shape.box_length / 2, w - t - g
    cx, z0 = -d + half_len, t + g
    add_panel(drawer, [cx, 0, z0 + wt / 2], [half_len, half_w, wt / 2], dmat)
    wall_z = z0 + shape.wall_height / 2
    for side in (1, -1):
        add_panel(drawer, [cx, side * (half_w - wt / 2), wall_z], [half_len, wt / 2, shape.wall_height / 2], dmat)
    add_panel(drawer, [cx + half_len - wt / 2, 0, wall_z], [wt / 2, half_w - wt, shape.wall_height / 2], dmat)
    # handle: the bar along y and a stem from each of its ends back to the front panel
    bar = shape.handle_centre()
    add_panel(drawer, bar, [shape.bar_half, shape.bar_half_length, shape.bar_half], hmat)
    stem_len = (shape.bar_standoff - shape.bar_half) / 2
    for side in (1, -1):
        add_panel(drawer, [shape.front_face_x - stem_len, side * (shape.bar_half_length - shape.bar_half), bar[2]],
             [stem_len, shape.bar_half, shape.bar_half], hmat)
    drawer.set_joint_name(f"{name}_slide")
    drawer.set_joint_properties(
        "prismatic", limits=[[0.0, shape.travel]], pose_in_parent=MINUS_X_AXIS_JOINT, pose_in_child=MINUS_X_AXIS_JOINT,
        friction=shape.friction, damping=shape.damping,
    )
    builder.initial_pose = sapien.Pose()
    return builder.build(name, fix_root_link=True)


def drawer_opening(cabinet) -> torch.Tensor:
    """(num_envs,) opening of the drawer (m): 0 closed."""
    return cabinet.get_qpos()[:, 0]
