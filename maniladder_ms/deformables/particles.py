"""Liquid and granular media as many small rigid spheres, with container metrics.

Liquid: low friction, no restitution, so the spheres flow and level out; granular (beans, grains):
high friction, so they pile and pour in clumps. Cost is dominated by sphere-sphere contacts: about
100 spheres keep a one-Panda scene near PickCube-v1's speed, 200 halve it.

Metrics (success rules of pouring tasks), on positions [B, N, 3]:
- `fraction_inside(positions, container_pose, shape)`: share of particles inside a container's inner
  volume (`maniladder_ms.objects.containers.ContainerShape.inside`);
- `fraction_spilled(positions, containers)`: share of particles inside none of the given containers;
- `inside_box(positions, pose, centre, half_size)`: which particles lie in a box fixed in a moving body
  (the hollow of a spoon's head), [B, N];
- `funnel_passage(positions, funnel_pose, shape, was_in_funnel)`: which particles are in a funnel now and which
  pass through its neck at this step (episode memory latches the second: a particle that went through the neck).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.structs.actor import Actor
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.objects.containers import ContainerShape

from .spheres import SphereSet, build_spheres


@dataclass(frozen=True)
class ParticleConfig:
    """count: number of spheres; radius (m); density (kg/m^3); friction: static = dynamic friction;
    restitution; color: RGBA of the spheres."""

    count: int = 100
    radius: float = 0.006
    density: float = 1000.0
    friction: float = 0.02
    restitution: float = 0.0
    color: tuple = (0.25, 0.5, 0.95, 1)


# particles' contact offset as a fraction of their radius; with the containers' own offset
# (CONTAINER_CONTACT_OFFSET) it catches a sphere falling at ~1 m/s before it reaches a wall
CONTACT_OFFSET_FRACTION = 0.5

LIQUID = ParticleConfig()
GRANULAR = ParticleConfig(radius=0.006, density=1200.0, friction=0.9, color=(0.55, 0.32, 0.15, 1))


class Particles(SphereSet):
    """A built set of liquid / granular spheres (a `SphereSet`) and the config they were made from."""

    def __init__(self, spheres: list[Actor], name: str, config: ParticleConfig):
        super().__init__(spheres, name)
        self.config = config

    def set_positions(self, xyz: torch.Tensor):
        """Place the spheres at `xyz` [b, N, 3] (b = envs being reset), at rest."""
        self.place(xyz.transpose(0, 1).reshape(-1, 3))


def build_particles(scene: ManiSkillScene, name: str, config: ParticleConfig) -> Particles:
    """Build `config.count` spheres named `<name>_<i>`; place them with `Particles.set_positions`."""
    material = physx.PhysxMaterial(config.friction, config.friction, config.restitution)
    render_mat = sapien.render.RenderMaterial(base_color=list(config.color), roughness=0.2) if scene.can_render() else None

    def add_visual(builder, i: int):
        builder.add_sphere_visual(radius=config.radius, material=render_mat)

    # spread out at build time so they never start inside each other
    spread = np.stack([3 * config.radius * np.arange(config.count), np.zeros(config.count), np.zeros(config.count)], axis=1)
    spheres = build_spheres(scene, name, spread, config.radius, material, config.density,
                            CONTACT_OFFSET_FRACTION * config.radius, add_visual)
    return Particles(spheres, name, config)


def pack_in_container(shape: ContainerShape, count: int, radius: float, generator: torch.Generator = None) -> torch.Tensor:
    """Layered positions [count, 3] for spheres filling `shape` from its floor, in its local frame.

    A square lattice of spacing 2.1 * radius per layer, inside the inner wall with a radius of margin,
    jittered by 0.05 radius so the pile is not a perfectly balanced stack.
    """
    spacing = 2.1 * radius
    points: list[np.ndarray] = []
    z = shape.floor + radius * 1.05
    while len(points) < count:
        reach = float(shape.inner_radius(torch.tensor([z]))[0]) - radius * 1.2
        k = int(reach // spacing)
        grid = np.arange(-k, k + 1) * spacing
        xy = np.stack(np.meshgrid(grid, grid), axis=-1).reshape(-1, 2)
        xy = xy[np.linalg.norm(xy, axis=1) <= reach]
        if len(xy) == 0:
            raise ValueError(f"{shape.kind} is too narrow for spheres of radius {radius}")
        points += [np.array([x, y, z]) for x, y in xy]
        z += spacing
    out = torch.tensor(np.array(points[:count]), dtype=torch.float32)
    return out + (torch.rand(out.shape, generator=generator) - 0.5) * 0.1 * radius


def fill_upright(group: Particles, shape: ContainerShape, origins: torch.Tensor, generator: torch.Generator = None):
    """Place `group`'s spheres packed in upright containers of `shape` standing at `origins` [b, 3] (one
    container per env being reset; `pack_in_container` jitters each packing on its own)."""
    config = group.config
    local = torch.stack([pack_in_container(shape, config.count, config.radius, generator).to(origins.device)
                         for _ in range(len(origins))])
    group.set_positions(local + origins[:, None])


# ---- metrics --------------------------------------------------------------------------------------
def fraction_inside(positions: torch.Tensor, container_pose: Pose, shape: ContainerShape) -> torch.Tensor:
    """Share of particles [B, N, 3] inside the container's inner volume (below its rim), [B]."""
    return shape.inside(positions, container_pose).float().mean(dim=1)


def fraction_spilled(positions: torch.Tensor, containers: list[tuple[Pose, ContainerShape]]) -> torch.Tensor:
    """Share of particles [B, N, 3] in none of `containers` ((pose, shape) pairs), [B]."""
    held = torch.zeros(positions.shape[:2], dtype=torch.bool, device=positions.device)
    for pose, shape in containers:
        held |= shape.inside(positions, pose)
    return 1 - held.float().mean(dim=1)


def inside_box(positions: torch.Tensor, pose: Pose, centre, half_size) -> torch.Tensor:
    """Which particles [B, N, 3] (world) lie inside a box fixed in a body at `pose` (batched, B): the box's
    `centre` and `half_size` (3 floats each) in the body's frame, axes along the body's; [B, N] bool."""
    m = pose.to_transformation_matrix()  # [B, 4, 4]
    local = torch.einsum("bij,bni->bnj", m[:, :3, :3], positions - m[:, None, :3, 3])
    c = torch.as_tensor(centre, dtype=local.dtype, device=local.device)
    h = torch.as_tensor(half_size, dtype=local.dtype, device=local.device)
    return ((local - c).abs() <= h).all(dim=-1)


def funnel_passage(positions: torch.Tensor, funnel_pose: Pose, shape: ContainerShape,
                   was_in_funnel: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(in_funnel, through_neck), [B, N] bool each, for particles [B, N, 3] and a funnel (`containers.funnel()`
    shape, its neck's outlet at its frame's origin) at `funnel_pose` (batched).

    in_funnel: inside the funnel's cone or its neck's bore now. through_neck: in the neck's bore now, or
    `was_in_funnel` (the last step's in_funnel) and now below the outlet (funnel frame z < 0) within the mouth's
    radius of the axis: a particle falls out of the neck in less than a control step (1.2 m/s after a 7.5 cm
    drop: 6 cm a step at 20 Hz), so it is caught on either side of the outlet; one that leaves over the rim is
    still above the outlet a step later (it falls 1.2 cm from rest in 0.05 s)."""
    m = funnel_pose.to_transformation_matrix()
    local = torch.einsum("bij,bni->bnj", m[:, :3, :3], positions - m[:, None, :3, 3])
    z, r = local[..., 2], torch.linalg.norm(local[..., :2], dim=-1)
    in_funnel = shape.inside(positions, funnel_pose)
    neck_radius = shape.inner[0][1]
    in_neck = (z >= 0) & (z <= shape.inner[1][0]) & (r <= neck_radius)
    fell_out = was_in_funnel & (z < 0) & (r <= shape.rim_radius)
    return in_funnel, in_neck | fell_out
