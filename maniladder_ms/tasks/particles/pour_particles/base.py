"""What the pouring tasks share: a cup full of particles, a bowl to pour them into, and their metrics.

`CupToBowl` is a mixin for `ManiLadderEnv` tasks (before it in the bases): its `_load_scene` builds the
cup, the bowl and the particles, its `_initialize_episode` places them, and it measures where the
particles are (`pour_metrics`, on which the tasks' success rules stand). A task sets what differs (shapes,
names, `placement`, `particle_material`, ...) and extends `_load_scene` (after `super()`) with its own
episode memory.

The PourParticles family's rule, `held_pour_metrics`: at least `success_fraction` of the particles lie in
the receiving container, and every container named in `held_containers` was held (`ee.holds`) by its end
effector on every step since the first particle landed in the receiver (episode memory
`<container name>_let_go`, latched on a step with particles in the receiver and the container not held),
at success included. A pour that tips a container over, or lets go of the held bowl, does not count.
"""

from __future__ import annotations

from typing import ClassVar

import dataclasses

import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.objects import containers

from maniladder_ms.deformables import particles


class CupToBowl:
    """A plastic cup (inner radius 2.5 cm, 8 cm tall, 5.8 cm wide outside: a Panda gripper closes across
    it) holding `particle_config` particles, and a bowl (inner radius 8 cm at the rim, 5 cm tall).

    The roles are fixed (`self.cup` pours, `self.bowl` receives); a task may change their shapes and the
    names of their actors (`cup_name`, `bowl_name`, also their obs keys): a glass pouring into a cup.
    """

    cup_shape: ClassVar = containers.cup(radius=0.025, height=0.08, wall=0.004)
    bowl_shape: ClassVar = containers.bowl()
    cup_name: ClassVar[str] = "cup"
    bowl_name: ClassVar[str] = "bowl"
    # where the containers stand: `placement`, {"cup" / "bowl": ((x low, x high), (y low, y high))}, each
    # uniform, drawn in this dict's order; with `cup_either_side` the cup's y range is mirrored to a random side
    # of y = 0 (that side drawn first). By default the task's catalog params give it (`placement`, below), the
    # roles drawn in `placement_roles`' order; a task may set the dict itself instead
    placement_roles: ClassVar[tuple[str, ...]] = ("cup", "bowl")
    cup_either_side: ClassVar[bool] = False
    # the particles: `particle_material`'s spheres, `particle_radius` each, the task's `particle_count` param of
    # them (`particle_config`; a task whose params name them otherwise overrides that property)
    particle_material: ClassVar[particles.ParticleConfig] = particles.LIQUID
    particle_radius: ClassVar[float] = 0.004
    particle_name: ClassVar[str] = "water"  # names the particle actors (<name>_<i>) and their obs entry
    success_fraction: ClassVar[float] = 0.8
    # two restores of one state into a scene that simulated on part by 4e-5 to 4e-4 m over 5 steps (PhysX
    # solver data outside the env state; measured on 80 beans resting in the cup): state checks use fresh scenes
    RESTORES_NEED_FRESH_SCENE: ClassVar[bool] = True
    cup_density: ClassVar[float] = 800.0  # ~50 g
    cup_friction: ClassVar[float] = 2.0  # grippy: a level side grasp holds it through a pour
    bowl_density: ClassVar[float] = containers.CERAMIC_DENSITY
    bowl_color: ClassVar[tuple] = (0.35, 0.55, 0.75, 1)
    # "cup" / "bowl" (the roles) -> the side (`ee.sides`) that must hold that container while particles land
    # in the bowl (`held_pour_metrics`); empty: nothing need be held
    held_containers: ClassVar[dict[str, str]] = {}

    @property
    def particle_config(self) -> particles.ParticleConfig:
        return dataclasses.replace(self.particle_material, count=self.particle_count, radius=self.particle_radius)

    @property
    def placement(self) -> dict[str, tuple]:
        """{role: (x range, y range)} from the catalog params `<name>_x_range` and `<name>_y_range` of each
        container (`<name>_abs_y_range` for the cup with `cup_either_side`), <name> its `cup_name` /
        `bowl_name`, in `placement_roles`' order."""
        out = {}
        for role in self.placement_roles:
            name = getattr(self, role + "_name")
            y = "abs_y" if role == "cup" and self.cup_either_side else "y"
            out[role] = (getattr(self, f"{name}_x_range"), getattr(self, f"{name}_{y}_range"))
        return out

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self._load_cup_and_bowl()

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            self._place_cup_and_bowl(len(env_idx))

    def _load_cup_and_bowl(self):
        self.cup = containers.build_container(self.scene, self.cup_name, self.cup_shape, color=(0.9, 0.9, 0.92, 1),
                                              friction=self.cup_friction, density=self.cup_density)
        self.bowl = self._build_bowl()
        self.particles = particles.build_particles(self.scene, self.particle_name, self.particle_config)
        for role in self.held_containers:
            self.memory.flag(self._let_go_field(role))

    def _build_bowl(self):
        """The receiving container's actor (a task whose receiver is not a CoACD container overrides it)."""
        return containers.build_container(self.scene, self.bowl_name, self.bowl_shape, color=self.bowl_color,
                                          density=self.bowl_density)

    def _let_go_field(self, role: str) -> str:
        return f"{getattr(self, role + '_name')}_let_go"

    def container_holds(self) -> dict[str, torch.Tensor]:
        """{role: (B,) bool}: each of `held_containers` is held by its side now."""
        return {role: self.ee.holds(getattr(self, role), side) for role, side in self.held_containers.items()}

    def _update_memory(self):
        super()._update_memory()
        if not self.held_containers:
            return
        pouring = particles.fraction_inside(self.particles.positions(), self.bowl.pose, self.bowl_shape) > 0
        for role, held in self.container_holds().items():
            self.memory.latch(self._let_go_field(role), pouring & ~held)

    def _place_cup_and_bowl(self, b: int):
        """Stand the cup and the bowl upright at random `placement`s in `b` sub-scenes being reset (call
        under `torch.device(self.device)`), the particles packed in the cup."""
        side = torch.where(torch.rand(b) < 0.5, -1.0, 1.0) if self.cup_either_side else None
        xyz = {}
        for name, (x_range, y_range) in self.placement.items():
            x, y = _uniform(b, *x_range), _uniform(b, *y_range)
            if name == "cup" and side is not None:
                y = side * y
            xyz[name] = torch.stack([x, y, torch.zeros(b)], dim=1)
        self.cup.set_pose(Pose.create_from_pq(xyz["cup"]))
        self.bowl.set_pose(Pose.create_from_pq(xyz["bowl"]))
        particles.fill_upright(self.particles, self.cup_shape, xyz["cup"])

    def _cup_and_bowl_obs(self) -> dict:
        return {f"{self.cup_name}_pose": self.cup.pose.raw_pose, f"{self.bowl_name}_pose": self.bowl.pose.raw_pose,
                f"{self.particle_name}_positions": self.particles.positions().flatten(1)}

    def pour_metrics(self) -> dict:
        """success (at least `success_fraction` of the particles in the bowl) and the shares of particles
        in the bowl, in the cup and elsewhere, [B] each."""
        p = self.particles.positions()
        in_bowl = particles.fraction_inside(p, self.bowl.pose, self.bowl_shape)
        in_cup = particles.fraction_inside(p, self.cup.pose, self.cup_shape)
        return {"success": in_bowl >= self.success_fraction, "fraction_in_bowl": in_bowl, "fraction_in_cup": in_cup,
                "fraction_spilled": 1 - in_bowl - in_cup}

    def held_pour_metrics(self) -> dict:
        """`pour_metrics` with the family's rule (module docstring): success also needs each of
        `held_containers` held now and never let go of since the first particle landed in the bowl. Adds
        `<container name>_held` (now) and `<container name>_let_go` (memory), [B] each."""
        metrics = self.pour_metrics()
        success = metrics["success"]
        for role, held in self.container_holds().items():
            let_go = self.memory[self._let_go_field(role)]
            success = success & held & ~let_go
            metrics[f"{getattr(self, role + '_name')}_held"] = held
            metrics[self._let_go_field(role)] = let_go
        metrics["success"] = success
        return metrics

    def pour_reward(self, info: dict) -> torch.Tensor:
        """The particles' part of the dense reward: the share in the bowl, less what was spilled, [0, 1]."""
        return info["fraction_in_bowl"] * (1 - info["fraction_spilled"])


def base_inside(p: torch.Tensor, container_pose: Pose, shape) -> torch.Tensor:
    """(B,) the points `p` (B, 3) (an object's base centre: a glass dropped into a bowl) lie within the
    container's rim circle, in its horizontal plane, and below its rim (the container taken as upright)."""
    rel = p - container_pose.p
    return (torch.linalg.norm(rel[:, :2], dim=1) < shape.rim_radius) & (rel[:, 2] < shape.height)


def _uniform(b: int, low: float, high: float) -> torch.Tensor:
    """[b] uniform draws in [low, high]: `(rand - 0.5) * width` for a range centred on 0, else
    `rand * width + low`. The two forms are the float32 expressions the pour tasks drew before the
    placement table; `rand * width + low` on a centred range differs from them by up to 3.7e-9 m, enough
    for the particle piles to diverge (committed samples drifted by 13 and 18 in state) -- keep them exact."""
    if low == -high:
        return (torch.rand(b) - 0.5) * (high - low)
    return torch.rand(b) * (high - low) + low
