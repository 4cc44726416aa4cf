"""Procedural containers (cup, glass, bowl, pitcher with spout, scoop, bottle, funnel) for liquid and granular
tasks and for grasping.

Each container is a solid of revolution about its local z axis (trimesh), origin at the centre of
its bottom face, so it stands on the table at z = 0. Its collision is a convex decomposition by
CoACD: the shapes the tasks use ship with the package (`objects.convex_cache`), any other is computed once
and cached under `maniladder_ms.paths.cache_dir("containers")` (a few seconds to ~20 s per shape the first
time, instant afterwards); a sealed bottle (`build_bottle`) collides as its convex hull instead. The
pitcher's spout is a bulge of its rim towards +x; pitcher and scoop handles are boxes on the -x side.

Open shells whose walls must be exact where particles pass (a funnel, an open narrow bottle, a ring stand) collide
as sector hulls instead (`shell_hulls`: each wall segment of the profile cut into `SHELL_SECTIONS` convex pieces
around the axis, no CoACD, the same on every install): `build_funnel`, `build_open_vessel`, `build_ring_stand`.

`ContainerShape.inside` tells which points lie in the container's inner volume (metrics such as the
fraction of particles in a cup build on it; see `maniladder_ms.deformables.particles`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch
import trimesh

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.paths import cache_dir

from .convex_cache import cached_convex_parts, mesh_key

SECTIONS = 32  # facets around the axis
COACD_THRESHOLD = 0.05  # CoACD concavity threshold: lower is finer (more hulls, slower)
COACD_MAX_HULLS = 16
CONTACT_OFFSET = 0.005  # m, below ManiSkill's 2 cm default: particles near the walls stay cheap
CERAMIC_DENSITY = 1200.0  # kg/m^3, light enough for a Panda to lift a full pitcher


@dataclass(frozen=True)
class ContainerShape:
    """A container as a revolved wall profile.

    kind: a name (cup, glass, bowl, pitcher, scoop, bottle); inner: (z, inner radius) samples of the inner
    wall from the inner floor (first) to the rim (last), metres; wall: wall thickness; floor: bottom
    thickness; spout: how far the pitcher's rim bulges out at +x (0: none); handle: half size (x, y, z)
    of a box handle on the -x side, or None.
    """

    kind: str
    inner: tuple[tuple[float, float], ...]
    wall: float
    floor: float
    spout: float = 0.0
    handle: Optional[tuple[float, float, float]] = None

    @property
    def height(self) -> float:
        return self.inner[-1][0]

    @property
    def rim_radius(self) -> float:
        return self.inner[-1][1]

    def profile(self) -> np.ndarray:
        """Closed (radius, z) polygon of the wall section: outer wall up, inner wall down to the axis."""
        outer = [(0.0, 0.0), (self.inner[0][1] + self.wall, 0.0)] + [(r + self.wall, z) for z, r in self.inner]
        inside = [(r, z) for z, r in self.inner[::-1]]
        return np.array(outer + inside + [(0.0, self.floor)])

    def inner_radius(self, z: torch.Tensor) -> torch.Tensor:
        """Inner wall radius at heights z (clamped to the floor..rim range)."""
        zs = torch.tensor([p[0] for p in self.inner], dtype=z.dtype, device=z.device)
        rs = torch.tensor([p[1] for p in self.inner], dtype=z.dtype, device=z.device)
        z = z.clamp(zs[0], zs[-1])
        k = torch.searchsorted(zs, z.contiguous()).clamp(1, len(zs) - 1)
        t = (z - zs[k - 1]) / (zs[k] - zs[k - 1]).clamp_min(1e-9)
        return rs[k - 1] + t * (rs[k] - rs[k - 1])

    def inside(self, points: torch.Tensor, pose: Pose) -> torch.Tensor:
        """Which of `points` [B, N, 3] (world) lie inside the inner volume, below the rim; [B, N] bool.

        `pose` is the container's batched pose (e.g. `actor.pose`).
        """
        m = pose.to_transformation_matrix()  # [B, 4, 4]
        local = torch.einsum("bij,bni->bnj", m[:, :3, :3], points - m[:, None, :3, 3])
        z = local[..., 2]
        r = torch.linalg.norm(local[..., :2], dim=-1)
        return (z >= self.floor) & (z <= self.height) & (r <= self.inner_radius(z))


def cup(radius: float = 0.035, height: float = 0.08, wall: float = 0.004, floor: float = 0.005) -> ContainerShape:
    """A straight cup; radius is the inner radius."""
    return ContainerShape("cup", ((floor, radius), (height, radius)), wall, floor)


def glass(bottom_radius: float = 0.025, top_radius: float = 0.033, height: float = 0.1, wall: float = 0.003,
          floor: float = 0.008) -> ContainerShape:
    """A drinking glass widening from bottom_radius to top_radius (inner radii)."""
    return ContainerShape("glass", ((floor, bottom_radius), (height, top_radius)), wall, floor)


def bowl(radius: float = 0.08, height: float = 0.05, foot_radius: float = 0.035, wall: float = 0.005,
         floor: float = 0.006, samples: int = 6) -> ContainerShape:
    """A bowl: flat inner floor of foot_radius, then a quarter-ellipse wall out to radius at the rim."""
    angles = np.linspace(0, np.pi / 2, samples)
    inner = [(floor + (height - floor) * (1 - np.cos(a)), foot_radius + (radius - foot_radius) * np.sin(a)) for a in angles]
    return ContainerShape("bowl", tuple((float(z), float(r)) for z, r in inner), wall, floor)


def pitcher(radius: float = 0.04, height: float = 0.12, wall: float = 0.004, floor: float = 0.006,
            spout: float = 0.02) -> ContainerShape:
    """A straight pitcher whose rim bulges `spout` metres out at +x (a pouring lip), box handle at -x."""
    handle = (0.008, 0.01, 0.35 * height)
    return ContainerShape("pitcher", ((floor, radius), (height, radius)), wall, floor, spout, handle)


def scoop(radius: float = 0.03, depth: float = 0.03, wall: float = 0.003, floor: float = 0.004,
          handle_length: float = 0.12) -> ContainerShape:
    """A small shallow cup with a long flat handle sticking out at -x (its top level with the rim)."""
    return ContainerShape("scoop", ((floor, radius), (depth, radius * 1.15)), wall, floor,
                          handle=(handle_length / 2, 0.008, 0.003))


def bottle(radius: float = 0.03, body_height: float = 0.1, shoulder_height: float = 0.02,
           neck_radius: float = 0.014, neck_height: float = 0.025, wall: float = 0.003,
           floor: float = 0.006) -> ContainerShape:
    """A bottle: straight body, conical shoulder, straight neck; radius and neck_radius are OUTER radii
    (what a hand closes on)."""
    r, n = radius - wall, neck_radius - wall
    inner = ((floor, r), (body_height, r), (body_height + shoulder_height, n),
             (body_height + shoulder_height + neck_height, n))
    return ContainerShape("bottle", inner, wall, floor)


def container_mesh(shape: ContainerShape) -> trimesh.Trimesh:
    """Watertight mesh of the container body (without the handle), origin at the bottom centre."""
    mesh = trimesh.creation.revolve(shape.profile(), sections=SECTIONS)
    if shape.spout > 0:
        v = mesh.vertices.copy()
        angle = np.arctan2(v[:, 1], v[:, 0])
        # a smooth bulge: strongest at the rim on +x, fading within 40 degrees and over the top third
        around = np.clip(1 - np.abs(angle) / np.radians(40), 0, 1) ** 2
        up = np.clip((v[:, 2] - 2 * shape.height / 3) / (shape.height / 3), 0, 1) ** 2
        radial = np.linalg.norm(v[:, :2], axis=1)
        grow = 1 + shape.spout * around * up / np.maximum(radial, 1e-6)
        v[:, :2] *= grow[:, None] * (radial[:, None] > 1e-6) + (radial[:, None] <= 1e-6)
        mesh = trimesh.Trimesh(v, mesh.faces)
    return mesh


def _handle_pose(shape: ContainerShape) -> sapien.Pose:
    hx, _, hz = shape.handle
    outer = shape.rim_radius + shape.wall
    if shape.kind == "scoop":  # flat handle level with the rim
        return sapien.Pose(p=[-(outer + hx - shape.wall), 0, shape.height - hz])
    return sapien.Pose(p=[-(outer + hx), 0, shape.height / 2])


def cached_parts(shape: ContainerShape) -> tuple[Path, list[Path]]:
    """(visual mesh file, convex part files) of the shape, decomposing with CoACD on a cache miss."""
    return cached_convex_parts(container_mesh(shape), shape.kind, COACD_THRESHOLD, COACD_MAX_HULLS, folder="containers")


def body_builder(scene: ManiSkillScene, shape: ContainerShape, color, density: float, friction: float):
    """(actor builder with the container's convex parts and visual, its physical material, its render
    material or None): what every vessel starts from before its handle is added."""
    visual, parts = cached_parts(shape)
    return builder_from_files(scene, visual, parts, color, density, friction)


def builder_from_files(scene: ManiSkillScene, visual, parts, color, density: float, friction: float):
    """(actor builder with convex collision `parts` and the `visual` mesh, physical material, render material
    or None)."""
    builder = scene.create_actor_builder()
    material = physx.PhysxMaterial(friction, friction, 0.0)
    for part in parts:
        builder.add_convex_collision_from_file(str(part), material=material, density=density)
    render_mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.3) if scene.can_render() else None
    if render_mat is not None:
        builder.add_visual_from_file(str(visual), material=render_mat)
    return builder, material, render_mat


def build_resting(builder, name: str):
    """Build a vessel at the origin (resting on z = 0) with the vessels' small contact offset."""
    builder.initial_pose = sapien.Pose()
    actor = builder.build(name=name)
    set_contact_offset(actor, CONTACT_OFFSET)
    return actor


def build_container(scene: ManiSkillScene, name: str, shape: ContainerShape, color=(0.9, 0.9, 0.92, 1),
                    density: float = CERAMIC_DENSITY, friction: float = 0.6):
    """Build the container as a dynamic actor resting on z = 0."""
    builder, material, render_mat = body_builder(scene, shape, color, density, friction)
    if shape.handle is not None:
        pose = _handle_pose(shape)
        builder.add_box_collision(pose=pose, half_size=shape.handle, material=material, density=density)
        if render_mat is not None:
            builder.add_box_visual(pose=pose, half_size=shape.handle, material=render_mat)
    return build_resting(builder, name)


def build_bottle(scene: ManiSkillScene, name: str, shape: ContainerShape, mass: float, color, friction: float = 0.8):
    """A sealed bottle (a `bottle()` shape) of `mass` kg as a dynamic actor resting on z = 0.

    It looks like the revolved container; it collides as the container's convex hull, one solid shape
    (exact: a bottle's profile never widens upwards). Fingers squeezing hard pushed through the thin CoACD
    wall parts of the open container and the bottle shot away when the hand lifted it (2 in 200 lifts).
    """
    mesh = container_mesh(shape)
    folder = cache_dir("containers", f"{shape.kind}_solid_{mesh_key(mesh, ['convex hull'])}")
    visual, hull_file = folder / "visual.obj", folder / "hull.obj"
    hull = mesh.convex_hull
    if not visual.exists():
        hull.export(hull_file)
        mesh.export(visual)  # written last: its presence marks a complete cache entry
    builder = scene.create_actor_builder()
    builder.add_convex_collision_from_file(str(hull_file), material=physx.PhysxMaterial(friction, friction, 0.0),
                                           density=mass / hull.volume)
    if scene.can_render():
        builder.add_visual_from_file(str(visual), material=sapien.render.RenderMaterial(base_color=list(color),
                                                                                        roughness=0.3))
    return build_resting(builder, name)


def set_contact_offset(actor, offset: float):
    """Contact offset (m) of all the actor's collision shapes in every sub-scene (before the sim starts)."""
    for body in actor._bodies:
        for collision_shape in body.get_collision_shapes():
            collision_shape.set_contact_offset(offset)


# ---- open shells as sector hulls: funnel, open bottle, ring stand -----------------------------------
SHELL_SECTIONS = 24  # sector hulls around the axis: a chord sits 0.9 % of its radius inside the circle


def funnel(mouth_radius: float = 0.045, cone_height: float = 0.045, neck_radius: float = 0.011,
           neck_length: float = 0.03, wall: float = 0.003, tab=(0.018, 0.005, 0.01)) -> ContainerShape:
    """A funnel: a straight neck (inner `neck_radius`, `neck_length` long, open at its bottom end, z = 0) under a
    cone widening to `mouth_radius` (inner) `cone_height` higher; `tab`: half size of a flat handle tab sticking
    out of the rim at +x (radial, tangential, vertical), its top flush with the rim. No floor (floor 0): `inside`
    is the cone and the neck's bore; `funnel_neck_top` is where the neck meets the cone."""
    inner = ((0.0, neck_radius), (neck_length, neck_radius), (neck_length + cone_height, mouth_radius))
    return ContainerShape("funnel", inner, wall, 0.0, handle=tuple(tab))


def funnel_neck_top(shape: ContainerShape) -> float:
    """Height of the funnel's neck top (where the cone starts) in its frame (the neck's outlet at z = 0)."""
    return shape.inner[1][0]


def funnel_tab_pose(shape: ContainerShape) -> sapien.Pose:
    """The handle tab's centre in the funnel's frame."""
    hx, _, hz = shape.handle
    return sapien.Pose(p=[shape.rim_radius + shape.wall + hx - 0.001, 0.0, shape.height - hz])


def ring(radius: float = 0.02, height: float = 0.05, wall: float = 0.004, seat_height: float = 0.0,
         seat_slope: float = 0.0) -> ContainerShape:
    """An open tube (inner `radius`, `height` tall), no floor, widening above into a conical seat `seat_height`
    tall (its inner radius growing `seat_slope` per metre up): a stand a funnel rests in by its cone."""
    inner = ((0.0, radius), (height, radius))
    if seat_height > 0:
        inner += ((height + seat_height, radius + seat_slope * seat_height),)
    return ContainerShape("ring", inner, wall, 0.0)


def shell_hulls(shape: ContainerShape, sections: int = SHELL_SECTIONS) -> list[np.ndarray]:
    """Convex pieces (vertex arrays, metres, the shape's frame) of the shape's revolved wall (`wall` thick
    outward of the inner profile) cut into `sections` sectors, and of its floor (wedges) when `floor` > 0."""
    angles = np.linspace(0.0, 2 * np.pi, sections + 1)
    pieces = []
    for a0, a1 in zip(angles[:-1], angles[1:]):
        c = np.array([[np.cos(a0), np.sin(a0)], [np.cos(a1), np.sin(a1)]])
        for (z0, r0), (z1, r1) in zip(shape.inner[:-1], shape.inner[1:]):
            corners = [(r0, z0), (r0 + shape.wall, z0), (r1, z1), (r1 + shape.wall, z1)]
            pieces.append(np.array([[r * cx, r * cy, z] for r, z in corners for cx, cy in c]))
        if shape.floor > 0:
            r = shape.inner[0][1] + shape.wall
            pieces.append(np.array([[0.0, 0.0, z] for z in (0.0, shape.floor)]
                                   + [[r * cx, r * cy, z] for z in (0.0, shape.floor) for cx, cy in c]))
    return pieces


def shell_profile(shape: ContainerShape) -> np.ndarray:
    """Closed (radius, z) polygon of an open shell's wall band (no floor): outer wall up, inner wall down."""
    return np.array([(r + shape.wall, z) for z, r in shape.inner] + [(r, z) for z, r in shape.inner[::-1]])


def cached_pieces(mesh: trimesh.Trimesh, pieces: list[np.ndarray], name: str, settings: list) -> tuple[Path, list[Path]]:
    """(visual mesh file, convex piece files) of `pieces` (point sets, each written as its hull) with `mesh` as the
    visual, written once into the user cache under `shells/<name>_<key of mesh and settings>`."""
    folder = cache_dir("shells", f"{name}_{mesh_key(mesh, settings)}")
    visual, parts = folder / "visual.obj", []
    for k, piece in enumerate(pieces):
        parts.append(folder / f"piece_{k:03d}.obj")
        if not visual.exists():
            trimesh.convex.convex_hull(piece).export(parts[-1])
    if not visual.exists():
        mesh.export(visual)  # written last: its presence marks a complete cache entry
    return visual, parts


def _shell_files(shape: ContainerShape) -> tuple[Path, list[Path]]:
    """(visual mesh file, convex piece files) of `shell_hulls(shape)`, written once into the user cache."""
    mesh = trimesh.creation.revolve(shell_profile(shape) if shape.floor == 0 else shape.profile(), sections=SECTIONS)
    return cached_pieces(mesh, shell_hulls(shape), shape.kind, ["sector hulls", SHELL_SECTIONS])


def shell_builder(scene: ManiSkillScene, shape: ContainerShape, color, density: float, friction: float):
    """(actor builder with the shape's sector hulls and visual, physical material, render material or None)."""
    visual, parts = _shell_files(shape)
    return builder_from_files(scene, visual, parts, color, density, friction)


def build_open_vessel(scene: ManiSkillScene, name: str, shape: ContainerShape, color, density: float = CERAMIC_DENSITY,
                      friction: float = 0.6):
    """An open container (a `bottle()` with its mouth open, a cup) colliding as sector hulls, resting on z = 0."""
    builder, _, _ = shell_builder(scene, shape, color, density, friction)
    return build_resting(builder, name)


def build_funnel(scene: ManiSkillScene, name: str, shape: ContainerShape, color, density: float = 1000.0,
                 friction: float = 1.0):
    """A `funnel()` as a dynamic actor (sector hulls and its handle tab), its neck's outlet at the origin."""
    builder, material, render_mat = shell_builder(scene, shape, color, density, friction)
    pose = funnel_tab_pose(shape)
    builder.add_box_collision(pose=pose, half_size=shape.handle, material=material, density=density)
    if render_mat is not None:
        builder.add_box_visual(pose=pose, half_size=shape.handle, material=render_mat)
    return build_resting(builder, name)


def build_ring_stand(scene: ManiSkillScene, name: str, shape: ContainerShape, color):
    """A `ring()` as a kinematic actor standing on z = 0 (move it with `set_pose`)."""
    builder, _, _ = shell_builder(scene, shape, color, CERAMIC_DENSITY, 0.6)
    builder.initial_pose = sapien.Pose()
    actor = builder.build_kinematic(name=name)
    set_contact_offset(actor, CONTACT_OFFSET)
    return actor
