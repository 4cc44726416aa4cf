"""A cooking pot with two side handles and a stove plate, built from primitives (LiftPotToStove).

The pot is an open ring of `wall_segments` boxes round a disc floor, with a flat tab handle sticking out at
+-y just below the rim (a gripper takes a tab from above, fingers closing across it, along x). The actor's
origin is the centre of the bottom face. The stove plate is a kinematic disc standing on the table, its
origin at its bottom centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render

from mani_skill.envs.scene import ManiSkillScene

Z_CYLINDER = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])  # SAPIEN cylinders lie along x


@dataclass(frozen=True)
class PotShape:
    radius: float = 0.095  # outer
    height: float = 0.09
    wall: float = 0.008
    floor: float = 0.01
    wall_segments: int = 16
    handle_length: float = 0.05  # how far a tab sticks out from the wall
    handle_width: float = 0.03  # across (along x): what the fingers close on
    handle_thickness: float = 0.014
    handle_drop: float = 0.015  # the tabs' centre below the rim

    def handle_centre(self, side: int) -> np.ndarray:
        """Centre of the +y (`side` = 1) or -y (-1) tab, in the pot frame."""
        return np.array([0.0, side * (self.radius + self.handle_length / 2), self.height - self.handle_drop])

    def parts(self) -> list[tuple[sapien.Pose, list[float]]]:
        """(pose, half size) of the wall boxes and the handle tabs, pot frame."""
        n, r = self.wall_segments, self.radius - self.wall / 2
        half_chord = r * np.tan(np.pi / n) + self.wall / 2
        boxes = []
        for k in range(n):
            a = 2 * np.pi * k / n
            q = [np.cos(a / 2), 0, 0, np.sin(a / 2)]
            boxes.append((sapien.Pose(p=[r * np.cos(a), r * np.sin(a), self.height / 2], q=q),
                          [self.wall / 2, half_chord, self.height / 2]))
        for side in (1, -1):
            centre = self.handle_centre(side)
            centre[1] -= side * self.wall / 2  # reach into the wall so that tab and wall join
            boxes.append((sapien.Pose(p=centre),
                          [self.handle_width / 2, (self.handle_length + self.wall) / 2, self.handle_thickness / 2]))
        return boxes


def build_pot(scene: ManiSkillScene, name: str, shape: PotShape, density: float, color, handle_color):
    """The pot as a dynamic actor standing on z = 0."""
    builder = scene.create_actor_builder()
    body = sapien.render.RenderMaterial(base_color=list(color), roughness=0.3, metallic=0.6)
    handles = sapien.render.RenderMaterial(base_color=list(handle_color), roughness=0.6)
    floor = sapien.Pose(p=[0, 0, shape.floor / 2]) * Z_CYLINDER
    builder.add_cylinder_collision(floor, radius=shape.radius - shape.wall / 2, half_length=shape.floor / 2, density=density)
    builder.add_cylinder_visual(floor, radius=shape.radius - shape.wall / 2, half_length=shape.floor / 2, material=body)
    for i, (pose, half) in enumerate(shape.parts()):
        builder.add_box_collision(pose, half_size=half, density=density)
        builder.add_box_visual(pose, half_size=half, material=body if i < shape.wall_segments else handles)
    builder.initial_pose = sapien.Pose()
    return builder.build(name=name)


def build_stove_plate(scene: ManiSkillScene, name: str, radius: float, height: float, color, ring_color):
    """A round hot plate standing on the table (kinematic: tasks place it per episode): a dark disc with a
    lighter ring marking its rim."""
    builder = scene.create_actor_builder()
    disc = sapien.Pose(p=[0, 0, height / 2]) * Z_CYLINDER
    builder.add_cylinder_collision(disc, radius=radius, half_length=height / 2)
    builder.add_cylinder_visual(disc, radius=radius, half_length=height / 2,
                                material=sapien.render.RenderMaterial(base_color=list(ring_color), roughness=0.5))
    inner = sapien.Pose(p=[0, 0, height / 2 + 0.0005]) * Z_CYLINDER
    builder.add_cylinder_visual(inner, radius=0.8 * radius, half_length=height / 2,
                                material=sapien.render.RenderMaterial(base_color=list(color), roughness=0.7))
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)
