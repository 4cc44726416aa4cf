"""Hand tools: an L-shaped hook built from boxes for pulling objects from out of reach (HookCubeWithTool); a
star-shaped stamp with a handle for pressing an imprint into clay (StampClay); a rolling pin with two handles
(FlattenClayWithRoller)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

import numpy as np

import sapien
import sapien.physx as physx
import sapien.render
import torch
import trimesh

from mani_skill.envs.scene import ManiSkillScene

from maniladder_ms.deformables import metrics
from maniladder_ms.paths import cache_dir


@dataclass(frozen=True)
class HookShape:
    """A handle `handle_length` long along the tool's local x, and at its +x end a hook `hook_length` long
    sticking out along +y; both `width` wide and `height` high. The origin is the handle's centre."""

    handle_length: float
    hook_length: float
    width: float = 0.025
    height: float = 0.03

    def parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) of the handle, then the hook, in the tool frame."""
        w, h = self.width / 2, self.height / 2
        hook_x = self.handle_length / 2 - w
        return [([0.0, 0.0, 0.0], [self.handle_length / 2, w, h]),
                ([hook_x, w + self.hook_length / 2, 0.0], [w, self.hook_length / 2, h])]

    @property
    def pull_face_x(self) -> float:
        """Local x of the hook's inner face (towards the handle's far end), which pulls an object."""
        return self.handle_length / 2 - self.width

    @property
    def hook_span(self) -> tuple[float, float]:
        """Local y range the hook's pulling face covers."""
        return self.width / 2, self.width / 2 + self.hook_length


def build_hook(scene: ManiSkillScene, name: str, shape: HookShape, density: float, color,
               friction: float = 0.3) -> "Actor":
    """The hook as a dynamic actor lying flat (origin `shape.height` / 2 above the table); `friction`: its
    surface's (PhysX averages it with the other body's)."""
    builder = scene.create_actor_builder()
    material = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
    surface = physx.PhysxMaterial(friction, friction, 0.0)
    for centre, half in shape.parts():
        builder.add_box_collision(sapien.Pose(p=centre), half_size=half, material=surface, density=density)
        builder.add_box_visual(sapien.Pose(p=centre), half_size=half, material=material)
    builder.initial_pose = sapien.Pose(p=[0, 0, shape.height / 2])
    return builder.build(name=name)


@dataclass(frozen=True)
class StarStampShape:
    """A stamp: a star-shaped plate `plate` thick (its `arms` tips at radius `outer`, the valleys between
    them at `inner`; tip k at angle 2 pi k / arms in the stamp frame) with a square post (side 2 x
    `handle_half`, `handle_height` high) standing on its centre for a gripper to hold. The origin is the
    plate's bottom centre, z up."""

    outer: float
    inner: float
    arms: int = 5
    plate: float = 0.012
    handle_half: float = 0.01
    handle_height: float = 0.07

    def outline(self) -> np.ndarray:
        """[2 arms, 2] star outline: tip, valley, tip, ... counter-clockwise."""
        angles = np.arange(2 * self.arms) * np.pi / self.arms
        radii = np.where(np.arange(2 * self.arms) % 2 == 0, self.outer, self.inner)
        return np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=1)

    def convex_parts(self) -> list[np.ndarray]:
        """Vertex sets [k, 3] of the plate's convex parts (PhysX collides convex shapes only): the hub (the
        polygon of the valleys) and one triangular prism per arm (its tip and the two valleys beside it)."""
        outline = self.outline()
        valleys = outline[1::2]
        polygons = [valleys] + [np.stack([outline[2 * k], outline[2 * k + 1], outline[2 * k - 1]])
                                for k in range(self.arms)]
        return [np.concatenate([np.pad(p, ((0, 0), (0, 1))), np.pad(p, ((0, 0), (0, 1)), constant_values=self.plate)])
                for p in polygons]

    def contains(self, xy: torch.Tensor) -> torch.Tensor:
        """Whether stamp-frame points xy [..., 2] lie inside the star's outline."""
        return metrics.inside_star(xy, self.outer, self.inner, self.arms)


def build_star_stamp(scene: ManiSkillScene, name: str, shape: StarStampShape, density: float, color,
                     friction: float = 0.8) -> "Actor":
    """The stamp as a dynamic actor standing on its plate (origin at the plate's bottom centre). The plate's
    convex parts are written once as mesh files into the cache (`paths.cache_dir`), keyed by the shape."""
    builder = scene.create_actor_builder()
    material = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
    surface = physx.PhysxMaterial(friction, friction, 0.0)
    parts = shape.convex_parts()
    key = hashlib.sha1(np.round(np.concatenate(parts), 6).tobytes()).hexdigest()[:16]
    folder = cache_dir("meshes", f"star_stamp_{key}")
    for k, vertices in enumerate(parts):
        path = folder / f"part_{k:02d}.obj"
        if not path.exists():
            trimesh.Trimesh(vertices).convex_hull.export(path)
        builder.add_convex_collision_from_file(str(path), material=surface, density=density)
        builder.add_visual_from_file(str(path), material=material)
    handle = [shape.handle_half, shape.handle_half, shape.handle_height / 2]
    centre = sapien.Pose(p=[0, 0, shape.plate + shape.handle_height / 2])
    builder.add_box_collision(centre, half_size=handle, material=surface, density=density)
    builder.add_box_visual(centre, half_size=handle, material=material)
    builder.initial_pose = sapien.Pose(p=[0, 0, 0.001])
    return builder.build(name=name)


@dataclass(frozen=True)
class RollingPinShape:
    """A rolling pin along the tool's local y: a barrel (radius `barrel_radius`, `barrel_length` long)
    with a thinner handle (radius `handle_radius`, `handle_length` long) at each end. The origin is the
    barrel's centre."""

    barrel_radius: float = 0.02
    barrel_length: float = 0.14
    handle_radius: float = 0.012
    handle_length: float = 0.07

    @property
    def handle_offset(self) -> float:
        """Local |y| of each handle's centre."""
        return (self.barrel_length + self.handle_length) / 2


def build_rolling_pin(scene: ManiSkillScene, name: str, shape: RollingPinShape, density: float, color,
                      handle_color, friction: float = 0.3, handle_friction: float = 1.0) -> "Actor":
    """The rolling pin as a dynamic actor lying along its local y (the barrel on the table when the origin
    is `barrel_radius` up); SAPIEN's cylinders run along their local x, so each is turned a quarter about z."""
    builder = scene.create_actor_builder()
    along_y = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]
    barrel_mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.6)
    handle_mat = sapien.render.RenderMaterial(base_color=list(handle_color), roughness=0.6)
    barrel_surface = physx.PhysxMaterial(friction, friction, 0.0)
    handle_surface = physx.PhysxMaterial(handle_friction, handle_friction, 0.0)
    pose = sapien.Pose(q=along_y)
    builder.add_cylinder_collision(pose, radius=shape.barrel_radius, half_length=shape.barrel_length / 2,
                                   material=barrel_surface, density=density)
    builder.add_cylinder_visual(pose, radius=shape.barrel_radius, half_length=shape.barrel_length / 2, material=barrel_mat)
    for sign in (-1, 1):
        pose = sapien.Pose(p=[0, sign * shape.handle_offset, 0], q=along_y)
        builder.add_cylinder_collision(pose, radius=shape.handle_radius, half_length=shape.handle_length / 2,
                                       material=handle_surface, density=density)
        builder.add_cylinder_visual(pose, radius=shape.handle_radius, half_length=shape.handle_length / 2,
                                    material=handle_mat)
    builder.initial_pose = sapien.Pose(p=[0, 0, shape.barrel_radius])
    return builder.build(name=name)


@dataclass(frozen=True)
class SpoonShape:
    """A flat-bottomed spoon (a scoop, like a dustpan) lying along its local x: the head, a base plate
    (inner area 2 x `head_half`, `plate` thick, its front edge bevelled over `bevel` down to `edge` thick,
    so it slides under a bean instead of pushing it) walled by rims `rim` thick and `rim_height` above the
    plate's top at the back and the sides and open at the front (+x), and behind it a straight handle
    (`handle_length` long, 2 x `handle_half` wide and high, its centre `handle_z` up: a riser on the back
    rim carries it, so it clears a bowl's rim while the head is down in the bowl) resting on a small foot
    at its far end, so the spoon lies level on the table. The origin is the centre of the plate's bottom
    face."""

    head_half: tuple[float, float] = (0.025, 0.022)
    plate: float = 0.004
    bevel: float = 0.012
    edge: float = 0.001
    rim: float = 0.004
    rim_height: float = 0.022
    handle_length: float = 0.1
    handle_half: float = 0.008
    handle_z: float = 0.05

    @property
    def back_x(self) -> float:
        """Local x of the back rim's outer face, where the handle starts."""
        return -self.head_half[0] - self.rim

    @property
    def front_x(self) -> float:
        """Local x of the plate's front edge."""
        return self.head_half[0]

    def plate_vertices(self) -> np.ndarray:
        """[10, 3] corners of the bevelled plate (a convex prism) in the spoon frame."""
        hx, hy = self.head_half
        p, b, e = self.plate, self.bevel, self.edge
        return np.array([[x, y, z] for y in (-hy - self.rim, hy + self.rim)
                         for x, z in ((-hx, 0.0), (hx, 0.0), (hx, e), (hx - b, p), (-hx, p))], dtype=float)

    def parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) boxes in the spoon frame (the plate is `plate_vertices`): back rim, side rims,
        riser, handle, foot."""
        hx, hy = self.head_half
        t, p = self.rim, self.plate
        wall = (p + self.rim_height) / 2
        h = self.handle_half
        handle_x = self.back_x - self.handle_length / 2
        foot_top = self.handle_z - h
        riser = (p + self.rim_height + self.handle_z + h) / 2  # from the back rim's top to the handle's top
        return [
            ([-hx - t / 2, 0.0, wall], [t / 2, hy + t, wall]),
            ([0.0, hy + t / 2, wall], [hx, t / 2, wall]),
            ([0.0, -hy - t / 2, wall], [hx, t / 2, wall]),
            ([-hx - t / 2, 0.0, riser], [t / 2, h, self.handle_z + h - riser]),
            ([handle_x, 0.0, self.handle_z], [self.handle_length / 2, h, h]),
            ([self.back_x - self.handle_length + 0.006, 0.0, foot_top / 2], [0.006, h, foot_top / 2]),
        ]

    def bowl_box(self, above: float) -> tuple[list[float], list[float]]:
        """(centre, half size) in the spoon frame of the head's hollow: the plate's inner area, from its bottom
        up to `above` over the rims' top (what a bean resting in the head occupies)."""
        top = self.plate + self.rim_height + above
        return [0.0, 0.0, top / 2], [self.head_half[0], self.head_half[1], top / 2]


def build_spoon(scene: ManiSkillScene, name: str, shape: SpoonShape, density: float, color,
                friction: float = 0.8) -> "Actor":
    """The spoon as a dynamic actor lying level on the table (origin at the plate's bottom centre, z = 0).
    The plate's convex prism is written once as a mesh file into the cache (`paths.cache_dir`), keyed by
    its corners."""
    builder = scene.create_actor_builder()
    material = sapien.render.RenderMaterial(base_color=list(color), roughness=0.4)
    surface = physx.PhysxMaterial(friction, friction, 0.0)
    vertices = shape.plate_vertices()
    key = hashlib.sha1(np.round(vertices, 6).tobytes()).hexdigest()[:16]
    path = cache_dir("meshes", f"spoon_plate_{key}") / "plate.obj"
    if not path.exists():
        trimesh.Trimesh(vertices).convex_hull.export(path)
    builder.add_convex_collision_from_file(str(path), material=surface, density=density)
    builder.add_visual_from_file(str(path), material=material)
    for centre, half in shape.parts():
        builder.add_box_collision(sapien.Pose(p=centre), half_size=half, material=surface, density=density)
        builder.add_box_visual(sapien.Pose(p=centre), half_size=half, material=material)
    builder.initial_pose = sapien.Pose(p=[0, 0, 0.001])
    return builder.build(name=name)
