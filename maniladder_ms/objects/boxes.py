"""Boxes: a box with a hinged lid, as a ManiSkill articulation built in code (OpenBoxRetrieval,
OpenLidHoldBox), and a closed carton (CarryBoxToShelfHands).

The body (root link) is an open box standing on z = 0; the lid is a plate hinged along the body's
top +x edge, opening upwards over +x, whose free (-x) edge overhangs the front wall as a lip that
fingers can lift from below. Joint 0 is the lid angle (0 closed, up to `max_angle`): pushed past
vertical, the lid falls onto its limit and stays open.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

from .tabletop import WOOD_DENSITY, open_box_parts

Y_AXIS_JOINT = sapien.Pose(q=[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])  # joint x axis (the hinge axis) along y


@dataclass(frozen=True)
class LiddedBoxShape:
    inner_half_size: tuple[float, float] = (0.07, 0.07)
    wall_height: float = 0.06
    wall_thickness: float = 0.01
    base_thickness: float = 0.01
    lid_thickness: float = 0.01
    lip: float = 0.03  # overhang of the lid beyond the front wall
    max_angle: float = np.deg2rad(110)

    @property
    def outer_half_size(self) -> tuple[float, float]:
        return tuple(h + self.wall_thickness for h in self.inner_half_size)

    def hinge_in_body(self) -> np.ndarray:
        return np.array([self.outer_half_size[0], 0.0, self.wall_height])

    @property
    def lid_length(self) -> float:
        return 2 * self.outer_half_size[0] + self.lip

    def lip_in_lid(self) -> np.ndarray:
        """Middle of the lip's free edge, bottom face, in the lid frame (origin on the hinge line, axes
        as the body's when closed)."""
        return np.array([-self.lid_length, 0.0, 0.0])


def build_lidded_box(scene: ManiSkillScene, name: str, shape: LiddedBoxShape, body_density: float, color,
                     lid_color, hinge_damping: float = 0.1):
    """The box articulation (free root); `body_density` sets how hard it is to push around."""
    builder = scene.create_articulation_builder()
    body = builder.create_link_builder()
    body.set_name(f"{name}_body")
    body_mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.6)
    for centre, half in open_box_parts(shape.inner_half_size, shape.wall_height, shape.wall_thickness,
                                       shape.base_thickness):
        body.add_box_collision(sapien.Pose(p=centre), half_size=half, density=body_density)
        body.add_box_visual(sapien.Pose(p=centre), half_size=half, material=body_mat)

    lid = builder.create_link_builder(body)
    lid.set_name(f"{name}_lid")
    lid_mat = sapien.render.RenderMaterial(base_color=list(lid_color), roughness=0.5)
    half_length = shape.lid_length / 2
    plate = sapien.Pose(p=[-half_length, 0, shape.lid_thickness / 2])
    plate_half = [half_length, shape.outer_half_size[1], shape.lid_thickness / 2]
    lid.add_box_collision(plate, half_size=plate_half, density=WOOD_DENSITY)
    lid.add_box_visual(plate, half_size=plate_half, material=lid_mat)
    lid.set_joint_name(f"{name}_hinge")
    lid.set_joint_properties(
        "revolute", limits=[[0.0, shape.max_angle]],
        pose_in_parent=sapien.Pose(p=shape.hinge_in_body()) * Y_AXIS_JOINT, pose_in_child=Y_AXIS_JOINT,
        friction=0.0, damping=hinge_damping,
    )
    builder.initial_pose = sapien.Pose()
    return builder.build(name, fix_root_link=False)


def lid_angle(box) -> torch.Tensor:
    return box.get_qpos()[:, 0]


def build_carton(scene: ManiSkillScene, name: str, half_size, mass: float, color, friction: float = 0.6,
                 tape_color=(0.85, 0.78, 0.6, 1)):
    """A closed carton (one box, `half_size` (x, y, z)) of `mass` kg as a dynamic actor standing on z = 0: its
    origin is the centre of its bottom face. A strip of tape runs over its top along x (visual only)."""
    hx, hy, hz = half_size
    builder = scene.create_actor_builder()
    centre = sapien.Pose(p=[0, 0, hz])
    builder.add_box_collision(centre, half_size=[hx, hy, hz], material=physx.PhysxMaterial(friction, friction, 0.0),
                              density=mass / (8 * hx * hy * hz))
    if scene.can_render():
        builder.add_box_visual(centre, half_size=[hx, hy, hz],
                               material=sapien.render.RenderMaterial(base_color=list(color), roughness=0.8))
        builder.add_box_visual(sapien.Pose(p=[0, 0, 2 * hz + 0.0005]), half_size=[hx + 0.0005, 0.025, 0.001],
                               material=sapien.render.RenderMaterial(base_color=list(tape_color), roughness=0.4))
    builder.initial_pose = sapien.Pose()
    return builder.build(name=name)
