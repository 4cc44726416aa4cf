"""Sets of small sphere actors: the particles that cloth, clay, liquid and grains are made of."""

from __future__ import annotations

from typing import Callable, Optional

import numpy as np
import sapien
import sapien.physx as physx
import torch

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.structs.actor import Actor
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.objects.containers import set_contact_offset


class SphereSet:
    """Sphere actors (one ManiSkill Actor each, batched over envs) and one merged view of them; the
    merged view is sphere-major: its row `i * b + e` is sphere i in env e."""

    def __init__(self, spheres: list[Actor], name: str):
        self.spheres = spheres
        self.merged = Actor.merge(spheres, name=name)

    def positions(self) -> torch.Tensor:
        """Sphere centres, [B, N, 3]."""
        if self.merged.scene.gpu_sim_enabled:
            p = self.merged.pose.p
        else:  # the same float32 centres, ~2x faster than ManiSkill's `pose` (a tensor per sapien.Pose) on 150 beans
            p = torch.from_numpy(np.stack([entity.pose.p for entity in self.merged._objs])).to(self.merged.device)
        return p.reshape(len(self.spheres), -1, 3).transpose(0, 1)

    def place(self, xyz: torch.Tensor, q: Optional[torch.Tensor] = None):
        """Put the spheres at `xyz` [N * b, 3] (sphere-major, b = envs being reset), with orientations
        `q` [N * b, 4] (default: identity), at rest."""
        self.merged.set_pose(Pose.create_from_pq(xyz, q))
        zeros = torch.zeros_like(xyz)
        self.merged.set_linear_velocity(zeros)
        self.merged.set_angular_velocity(zeros)


def build_spheres(scene: ManiSkillScene, name: str, positions: np.ndarray, radius: float,
                  material: physx.PhysxMaterial, density: float, contact_offset: float,
                  add_visual: Optional[Callable[[sapien.ActorBuilder, int], None]] = None) -> list[Actor]:
    """One dynamic sphere `<name>_<i>` per row of `positions` [N, 3], built 1 m above it (tasks place
    them at reset); `add_visual(builder, i)` draws sphere i when the scene renders.

    The contact offset is set per sphere: ManiSkill's default (2 cm) is bigger than a particle, and
    each sphere would track contacts with dozens of neighbours, the main cost of a particle scene.
    """
    spheres = []
    for i, p in enumerate(positions):
        builder = scene.create_actor_builder()
        builder.add_sphere_collision(radius=radius, material=material, density=density)
        if add_visual is not None and scene.can_render():
            add_visual(builder, i)
        builder.initial_pose = sapien.Pose(p=[float(p[0]), float(p[1]), float(p[2]) + 1.0])
        sphere = builder.build(name=f"{name}_{i}")
        set_contact_offset(sphere, contact_offset)
        spheres.append(sphere)
    return spheres
