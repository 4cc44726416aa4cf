"""A carrying basket: an open rectangular tub with tapered walls and a bar handle on each long side.

The tub is a closed mesh (outer walls, rim, inner walls, floor) whose collision is a CoACD convex
decomposition shipped with the package (`objects.convex_cache`); each handle is a round bar along the basket's
x axis, standing off the outer wall just below the rim on two posts, so a hand can close around it
(fingers on one side of the bar, thumb in the gap between bar and wall). The actor's origin is the
centre of the bottom face; the handles are at +-y.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import trimesh

from mani_skill.envs.scene import ManiSkillScene

from .convex_cache import cached_convex_parts

COACD_THRESHOLD = 0.04
COACD_MAX_HULLS = 12


@dataclass(frozen=True)
class BasketShape:
    """inner_bottom / inner_top: inner half sizes (x, y) at the floor and at the rim; height: rim height;
    wall, floor: thicknesses; handle_*: the bar (half length along x, radius), its centre's distance out
    from the outer rim edge and below the rim, and the posts' half thickness."""

    inner_bottom: tuple[float, float] = (0.07, 0.1)
    inner_top: tuple[float, float] = (0.08, 0.11)
    height: float = 0.1
    wall: float = 0.006
    floor: float = 0.008
    handle_half_length: float = 0.075
    handle_radius: float = 0.009
    handle_gap: float = 0.045
    handle_drop: float = 0.012
    post_half: float = 0.006

    def handle_centre(self, side: int) -> np.ndarray:
        """Centre of the handle bar on the +y (`side` = 1) or -y (-1) side, in the basket frame."""
        return np.array([0.0, side * (self.inner_top[1] + self.wall + self.handle_gap), self.height - self.handle_drop])


def tub_mesh(shape: BasketShape) -> trimesh.Trimesh:
    """Closed mesh of the tub: four rectangular rings (outer bottom, outer rim, inner rim, inner floor)
    joined by quads, the outer bottom and the inner floor capped."""
    (bx, by), (tx, ty), w = shape.inner_bottom, shape.inner_top, shape.wall
    corners = np.array([(1, 1), (-1, 1), (-1, -1), (1, -1)], dtype=float)  # counter-clockwise from above
    rings = [corners * (bx + w, by + w), corners * (tx + w, ty + w), corners * (tx, ty), corners * (bx, by)]
    heights = [0.0, shape.height, shape.height, shape.floor]
    vertices = np.concatenate([np.column_stack([r, np.full(4, z)]) for r, z in zip(rings, heights)])
    faces = []
    for k in range(3):  # ring k to ring k + 1: outer wall, rim, inner wall
        for i in range(4):
            a, b = 4 * k + i, 4 * k + (i + 1) % 4
            faces += [[a, b, b + 4], [a, b + 4, a + 4]]
    faces += [[0, 2, 1], [0, 3, 2], [12, 13, 14], [12, 14, 15]]  # bottom (facing down), inner floor (up)
    mesh = trimesh.Trimesh(vertices, np.array(faces), process=True)
    trimesh.repair.fix_normals(mesh)
    return mesh


def handle_boxes(shape: BasketShape, side: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(centre, half size) of the two posts joining the `side` handle bar to the wall, basket frame."""
    bar = shape.handle_centre(side)
    inner = side * shape.inner_top[1]  # posts start inside the wall so that they join it
    half_y = abs(bar[1] - inner) / 2
    posts = []
    for sx in (1, -1):
        centre = np.array([sx * (shape.handle_half_length - shape.post_half), (bar[1] + inner) / 2, bar[2]])
        posts.append((centre, np.array([shape.post_half, half_y, shape.post_half])))
    return posts


def build_basket(scene: ManiSkillScene, name: str, shape: BasketShape, mass: float, color,
                 friction: float = 0.8):
    """The basket as a dynamic actor of `mass` kg standing on z = 0."""
    visual, parts = cached_convex_parts(tub_mesh(shape), "basket", COACD_THRESHOLD, COACD_MAX_HULLS)
    bar_volume = np.pi * shape.handle_radius**2 * 2 * shape.handle_half_length
    post_volume = sum(np.prod(2 * half) for side in (1, -1) for _, half in handle_boxes(shape, side))
    volume = sum(trimesh.load(p).volume for p in parts) + 2 * bar_volume + post_volume
    density = mass / volume
    material = physx.PhysxMaterial(friction, friction, 0.0)
    render_mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
    builder = scene.create_actor_builder()
    for part in parts:
        builder.add_convex_collision_from_file(str(part), material=material, density=density)
    builder.add_visual_from_file(str(visual), material=render_mat)
    for side in (1, -1):
        bar = sapien.Pose(p=shape.handle_centre(side))
        half = shape.handle_half_length - shape.handle_radius
        builder.add_capsule_collision(bar, shape.handle_radius, half, material=material, density=density)
        builder.add_capsule_visual(bar, shape.handle_radius, half, material=render_mat)
        for centre, half_size in handle_boxes(shape, side):
            builder.add_box_collision(sapien.Pose(p=centre), half_size, material=material, density=density)
            builder.add_box_visual(sapien.Pose(p=centre), half_size, material=render_mat)
    builder.initial_pose = sapien.Pose()
    return builder.build(name=name)
