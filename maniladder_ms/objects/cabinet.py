"""A small two-door cabinet, as a ManiSkill articulation built in code (OpenDoubleDoorsHands and later levels).

The carcass (root link: back, sides, top, bottom, a middle shelf) stands on z = 0 with its open front
facing -x, origin at the centre of its footprint. Two doors cover the front, each hinged about a
vertical axis on its outer edge: the left door (+y half) on the +y edge, the right door on the -y edge.
Each door carries a knob handle `handle_from_hinge` from its hinge: a horizontal stem out of the door
front ending in an upright post, which a hand can close round from above and pull on in any direction. Joint i (0: left door, 1: right door) is the door's opening
angle: 0 closed, positive swinging the free edge out towards -x, up to `max_angle`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.structs.pose import Pose

from .tabletop import WOOD_DENSITY

# revolute joints turn about their frame's x axis: this rotation puts it along +z / -z of the parent
Z_AXIS_JOINT = sapien.Pose(q=[np.cos(np.pi / 4), 0, -np.sin(np.pi / 4), 0])
MINUS_Z_AXIS_JOINT = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
DOORS = ("left", "right")
DOOR_SIDE = {"left": 1, "right": -1}  # which half of the front (+y / -y) each door covers


@dataclass(frozen=True)
class CabinetShape:
    """Outer size (depth x, width y, height z), panel and door thickness, the knob handle (post radius and
    half length, stem height above the floor and distance from the hinge along the door, the post axis'
    stand-off from the door's front face, the stem's half thickness), the hinges' damping and the doors'
    opening limit."""

    depth: float = 0.22
    width: float = 0.4
    height: float = 0.32
    panel: float = 0.012
    door: float = 0.012
    post_radius: float = 0.025
    post_half_length: float = 0.04
    stem_height: float = 0.16
    handle_from_hinge: float = 0.08
    handle_standoff: float = 0.1
    stem_half: float = 0.008
    hinge_damping: float = 0.05
    max_angle: float = np.deg2rad(110)

    @property
    def door_width(self) -> float:
        return self.width / 2

    def hinge(self, door: str) -> np.ndarray:
        """Hinge axis point (at the bottom) in the cabinet frame: the door's outer front edge."""
        return np.array([-self.depth / 2, DOOR_SIDE[door] * self.width / 2, 0.0])

    def post_top(self, door: str) -> np.ndarray:
        """Top centre of the handle's post in the door's frame (origin on the hinge, axes as the cabinet's
        when closed)."""
        return np.array([-self.door - self.handle_standoff, -DOOR_SIDE[door] * self.handle_from_hinge,
                         self.stem_height + 2 * self.post_half_length])


def add_panel(link, centre, half, material):
    """A wooden box (collision and visual) on `link`, centred at `centre` with half sizes `half`."""
    link.add_box_collision(sapien.Pose(p=centre), half_size=half, density=WOOD_DENSITY)
    link.add_box_visual(sapien.Pose(p=centre), half_size=half, material=material)


def add_carcass(builder, name: str, shape, color, shelf: bool):
    """A cabinet's fixed body, the articulation's root link: back, two sides, bottom and top panels (and a middle
    shelf), from `shape`'s depth, width, height and panel thickness; open at the front (-x)."""
    carcass = builder.create_link_builder()
    carcass.set_name(f"{name}_carcass")
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.7)
    d, w, h, t = shape.depth / 2, shape.width / 2, shape.height, shape.panel
    add_panel(carcass, [d - t / 2, 0, h / 2], [t / 2, w, h / 2], mat)  # back
    for side in (1, -1):
        add_panel(carcass, [0, side * (w - t / 2), h / 2], [d, t / 2, h / 2], mat)
    for z in (t / 2, h - t / 2) + ((h / 2,) if shelf else ()):  # bottom, top (, shelf)
        add_panel(carcass, [0, 0, z], [d, w - t, t / 2], mat)
    return carcass


def build_cabinet(scene: ManiSkillScene, name: str, shape: CabinetShape, color, door_color, handle_color):
    """The cabinet articulation, its root fixed where `set_pose` puts it (a cabinet does not slide)."""
    builder = scene.create_articulation_builder()
    carcass = add_carcass(builder, name, shape, color, shelf=True)
    door_mat = sapien.render.RenderMaterial(base_color=list(door_color), roughness=0.6)
    handle_mat = sapien.render.RenderMaterial(base_color=list(handle_color), roughness=0.3, metallic=0.6)
    for door in DOORS:
        _add_door(builder, carcass, name, door, shape, door_mat, handle_mat)
    builder.initial_pose = sapien.Pose()
    return builder.build(name, fix_root_link=True)


def _add_door(builder, carcass, name: str, door: str, shape: CabinetShape, door_mat, handle_mat):
    side = DOOR_SIDE[door]
    link = builder.create_link_builder(carcass)
    link.set_name(f"{name}_{door}_door")
    gap = 0.002  # between the doors, and between door and carcass, so that closed doors do not rub
    half_w = shape.door_width / 2 - gap
    add_panel(link, [-shape.door / 2, -side * shape.door_width / 2, shape.height / 2],
           [shape.door / 2, half_w, shape.height / 2 - gap], door_mat)
    top = shape.post_top(door)
    # the post stands upright: a cylinder (its axis is its local x) turned by 90 degrees about y
    post = sapien.Pose(p=top - [0, 0, shape.post_half_length], q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
    link.add_cylinder_collision(post, shape.post_radius, shape.post_half_length, density=WOOD_DENSITY)
    link.add_cylinder_visual(post, shape.post_radius, shape.post_half_length, material=handle_mat)
    stem_len = shape.handle_standoff / 2
    add_panel(link, [-shape.door - stem_len, top[1], shape.stem_height], [stem_len, shape.stem_half, shape.stem_half],
           handle_mat)
    axis = MINUS_Z_AXIS_JOINT if side > 0 else Z_AXIS_JOINT  # opening swings the free edge towards -x
    link.set_joint_name(f"{name}_{door}_hinge")
    link.set_joint_properties(
        "revolute", limits=[[0.0, shape.max_angle]], pose_in_parent=sapien.Pose(p=shape.hinge(door)) * axis,
        pose_in_child=axis, friction=0.0, damping=shape.hinge_damping,
    )


def door_angles(cabinet) -> torch.Tensor:
    """(num_envs, 2) opening angles (rad) of the left and right doors."""
    return cabinet.get_qpos()[:, :2]


def door_frame(cabinet, shape: CabinetShape, door: str, angle: torch.Tensor) -> Pose:
    """World pose of `door`'s frame (origin on its hinge) opened to `angle` (num_envs,), from the carcass pose."""
    side = DOOR_SIDE[door]
    half = -side * angle / 2  # the left door turns about -z
    q = torch.stack([torch.cos(half), torch.zeros_like(half), torch.zeros_like(half), torch.sin(half)], dim=1)
    hinge = torch.as_tensor(shape.hinge(door), dtype=torch.float32, device=angle.device)[None].expand(len(angle), 3)
    return cabinet.pose * Pose.create_from_pq(hinge, q)
