"""A square peg and a block with a blind square hole, built from boxes (the InsertPeg family).

The peg is a box `2 * half_side` square and `length` long along its local z; its origin is its centre.
The hole block's origin lies on the hole's axis at the block's bottom face (it stands on z = 0), its z axis
the hole's axis: a base plate `base` thick, then four walls `wall` thick around a square hole of half side
`hole_half`, `depth` deep, so the rim is at z = `base + depth`. An optional `handle` (a solid bar as tall
as the walls) extends the block along its local +x: where a gripper holds it without covering the hole.
"""

from __future__ import annotations

from dataclasses import dataclass

import sapien
import sapien.render

from mani_skill.envs.scene import ManiSkillScene

from .tabletop import WOOD_DENSITY


@dataclass(frozen=True)
class HoleBlockShape:
    hole_half: float  # half side of the square hole
    depth: float  # from the rim down to the hole's floor
    wall: float = 0.01
    base: float = 0.01
    handle: float = 0.0  # length of the solid bar along +x beyond the +x wall (0: none)

    @property
    def rim_height(self) -> float:
        return self.base + self.depth

    @property
    def outer_half(self) -> float:
        """Half side of the square part around the hole."""
        return self.hole_half + self.wall

    def parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) boxes in the block frame: base plate, the walls at +-x, at +-y, the handle."""
        h, o, t, z = self.hole_half, self.outer_half, self.wall, self.rim_height
        parts = [
            ([0, 0, self.base / 2], [o, o, self.base / 2]),
            ([h + t / 2, 0, (self.base + z) / 2], [t / 2, o, self.depth / 2]),
            ([-h - t / 2, 0, (self.base + z) / 2], [t / 2, o, self.depth / 2]),
            ([0, h + t / 2, (self.base + z) / 2], [h, t / 2, self.depth / 2]),
            ([0, -h - t / 2, (self.base + z) / 2], [h, t / 2, self.depth / 2]),
        ]
        if self.handle > 0:
            parts.append(([o + self.handle / 2, 0, z / 2], [self.handle / 2, o, z / 2]))
        return parts


def build_hole_block(scene: ManiSkillScene, name: str, shape: HoleBlockShape, color, rim_color=None,
                     kinematic: bool = False, density: float = WOOD_DENSITY) -> "Actor":
    """The block (see the module docstring); `kinematic` fixes it where `set_pose` puts it (a fixture);
    `rim_color` marks the hole's rim with a thin visual frame."""
    builder = scene.create_actor_builder()
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.6)
    for centre, half in shape.parts():
        builder.add_box_collision(pose=sapien.Pose(p=centre), half_size=half, density=density)
        builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half, material=mat)
    if rim_color is not None:  # a band around the opening, 1 mm proud of the top face
        rim = sapien.render.RenderMaterial(base_color=list(rim_color), roughness=0.6)
        h, t, z = shape.hole_half, shape.wall / 3, shape.rim_height + 0.0005
        for centre, half in (([h + t / 2, 0, z], [t / 2, h + t, 0.0005]), ([-h - t / 2, 0, z], [t / 2, h + t, 0.0005]),
                             ([0, h + t / 2, z], [h, t / 2, 0.0005]), ([0, -h - t / 2, z], [h, t / 2, 0.0005])):
            builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half, material=rim)
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name) if kinematic else builder.build(name=name)


def build_square_peg(scene: ManiSkillScene, name: str, half_side: float, length: float, color, tip_color,
                     density: float = WOOD_DENSITY) -> "Actor":
    """The peg (see the module docstring), its lower end (`-z`) marked in `tip_color` over a fifth of its length."""
    builder = scene.create_actor_builder()
    builder.add_box_collision(half_size=[half_side, half_side, length / 2], density=density)
    body = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
    tip = sapien.render.RenderMaterial(base_color=list(tip_color), roughness=0.5)
    tip_len = length / 5
    builder.add_box_visual(pose=sapien.Pose(p=[0, 0, tip_len / 2]), half_size=[half_side, half_side, length / 2 - tip_len / 2],
                           material=body)
    builder.add_box_visual(pose=sapien.Pose(p=[0, 0, -length / 2 + tip_len / 2]),
                           half_size=[half_side * 1.001, half_side * 1.001, tip_len / 2], material=tip)
    builder.initial_pose = sapien.Pose(p=[0, 0, length / 2])
    return builder.build(name=name)
