"""One small demo scene per deformable kind, on the ManiLadder table with the default Panda.

They are not ladder tasks (task_id=None): each shows one builder of `maniladder_ms.deformables`
at work, exposes its metrics in `info`, and is what `maniladder bench --scene <kind>` times. Every
scene holds at least one dynamic actor besides the deformable (ManiSkill 3.0.1's set_state fails
on scenes without one). The state obs carries the deformable's points, so a state round trip
checks them too.
"""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.utils.registration import register_env
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects import containers
from maniladder_ms.objects.tabletop import build_upright_cylinder

from . import clay, cloth, metrics, particles, rope

SHOWCASE_ENV_IDS: dict[str, str] = {}
SHOWCASE_STEPS = 200


def _register(kind: str):
    def decorate(cls):
        env_id = f"ManiLadderShowcase-{kind.capitalize()}-v1"
        SHOWCASE_ENV_IDS[kind] = env_id
        return register_env(env_id, max_episode_steps=SHOWCASE_STEPS)(cls)

    return decorate


class ShowcaseEnv(ManiLadderEnv):
    """Base of the showcase scenes: no catalog task, the robot's TCP pose in the obs."""

    SHOWCASE_TITLE: ClassVar[str] = ""
    SUPPORTED_REWARD_MODES = ("none",)  # demos, not tasks: no reward

    def __init__(self, *args, **kwargs):
        super().__init__(*args, task_id=None, **kwargs)

    def deformable_points(self) -> torch.Tensor:
        """The points that make up the deformable, [B, N, 3] (part of the state obs)."""
        raise NotImplementedError

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose)
        if "state" in self.obs_mode:
            obs["deformable_points"] = self.deformable_points().flatten(1)
        return obs


@_register("rope")
class RopeShowcaseEnv(ShowcaseEnv):
    """A 40 cm, 20-capsule rope lying in a gentle S on the table beside a free-standing peg."""

    SHOWCASE_TITLE = "Rope: 20-capsule chain, 40 cm, free"
    rope_config = rope.RopeConfig()
    peg_radius = 0.02
    peg_half_height = 0.04

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.rope = rope.build_rope(self.scene, "rope", self.rope_config)
        self.peg = build_upright_cylinder(self.scene, "peg", self.peg_radius, self.peg_half_height, 800,
                                          (0.3, 0.5, 0.3, 1))

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            cfg = self.rope_config
            start = torch.tensor([[-0.05, -0.2, cfg.radius]]).repeat(b, 1)
            start[:, 0] += (torch.rand(b) - 0.5) * 0.05
            bend = torch.zeros(b, 2 * (cfg.segments - 1))
            phase = torch.rand(b, 1) * 2 * np.pi
            k = torch.arange(1, cfg.segments)
            bend[:, 0::2] = 0.25 * torch.sin(2 * np.pi * k / cfg.segments + phase)  # in-plane S curve
            self.rope.set_shape(Pose.create_from_pq(start, yaw_quat(torch.full((b,), np.pi / 2))), bend)
            self.peg.set_pose(Pose.create_from_pq(torch.tensor([[0.1, 0.0, self.peg_half_height]]).repeat(b, 1)))

    def deformable_points(self):
        return self.rope.points()

    def evaluate(self):
        points = self.rope.points()
        return dict(
            straightness=rope.straightness(points),
            end_to_end=rope.end_to_end_distance(points),
            winding_about_peg=rope.winding_number(points, self.peg.pose.p[:, :2]),
        )


def _build_box(scene, name: str, half_size, color) -> "Actor":
    """A dynamic wooden box resting on z = 0 (a support to drape cloth over, or a cube to handle)."""
    builder = scene.create_actor_builder()
    builder.add_box_collision(half_size=half_size, density=600)
    if scene.can_render():
        builder.add_box_visual(half_size=half_size, material=sapien.render.RenderMaterial(base_color=list(color), roughness=0.6))
    builder.initial_pose = sapien.Pose(p=[0, 0, half_size[2]])
    return builder.build(name=name)


class ClothShowcaseEnv(ShowcaseEnv):
    """A sheet dropped from `drop_height` onto the table, over a box at `box_xy` (its support or a prop)."""

    cloth_config = cloth.ClothConfig()
    cloth_xy = (0.05, 0.0)
    drop_height = 0.0
    box_half_size = (0.02, 0.02, 0.02)
    box_xy = (0.05, 0.2)
    box_color = (0.6, 0.45, 0.3, 1)

    def _layout(self) -> cloth.ClothLayout:
        raise NotImplementedError

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.cloth = cloth.build_cloth(self.scene, "cloth", self._layout(), self.cloth_config)
        self.box = _build_box(self.scene, "box", self.box_half_size, self.box_color)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            box = torch.tensor([[self.box_xy[0], self.box_xy[1], self.box_half_size[2]]]).repeat(b, 1)
            self.box.set_pose(Pose.create_from_pq(box))
            z = self.cloth_config.radius + self.drop_height
            self.cloth.set_rest_shape(Pose.create_from_pq(torch.tensor([[self.cloth_xy[0], self.cloth_xy[1], z]]).repeat(b, 1)))

    def deformable_points(self):
        return self.cloth.positions()

    def evaluate(self):
        points = self.cloth.positions()
        return dict(
            covered_area=metrics.footprint_area(points, self.cloth_config.spacing),
            flatness=cloth.flatness(points),
        )


@_register("towel")
class TowelShowcaseEnv(ClothShowcaseEnv):
    """A 10 x 10 towel (25 cm) dropped over a 6 cm box: it drapes."""

    SHOWCASE_TITLE = "Towel: 10x10 particles (25 cm) draped over a box"
    box_half_size = (0.03, 0.03, 0.03)
    box_xy = (0.05, 0.0)
    drop_height = 0.07

    def _layout(self):
        return cloth.towel(10, 10, self.cloth_config.spacing)


@_register("shirt")
class ShirtShowcaseEnv(ClothShowcaseEnv):
    """A T-shirt outline (8 x 6 body, 3 x 3 sleeves) lying flat on the table."""

    SHOWCASE_TITLE = "Shirt: body 8x6 + sleeves 3x3, lying flat"
    cloth_config = cloth.ClothConfig(color=(0.85, 0.25, 0.25, 1), border_color=(0.6, 0.12, 0.12, 1))

    def _layout(self):
        return cloth.shirt(spacing=self.cloth_config.spacing)


@_register("bag")
class BagShowcaseEnv(ClothShowcaseEnv):
    """A 6 x 6 tote bag (two sewn panels, handle loops) lying flat, a cube beside it."""

    SHOWCASE_TITLE = "Bag: two sewn 6x6 panels with handles, lying flat, cube beside"
    cloth_config = cloth.ClothConfig(color=(0.85, 0.75, 0.45, 1), border_color=(0.45, 0.3, 0.15, 1))
    cloth_xy = (0.0, 0.0)
    box_xy = (0.05, 0.2)

    def _layout(self):
        return cloth.bag(spacing=self.cloth_config.spacing, radius=self.cloth_config.radius)


@_register("tent")
class TentShowcaseEnv(ClothShowcaseEnv):
    """An 8 x 12 tent panel (3 cm spacing) dropped over a long ridge box: a small tent."""

    SHOWCASE_TITLE = "Tent panel: 8x12 particles (24 x 36 cm) over a ridge"
    cloth_config = cloth.ClothConfig(spacing=0.03, radius=0.009, color=(0.3, 0.55, 0.25, 1), border_color=(0.9, 0.75, 0.2, 1))
    box_half_size = (0.015, 0.2, 0.05)
    box_xy = (0.05, 0.0)
    drop_height = 0.11

    def _layout(self):
        return cloth.tent_panel(spacing=self.cloth_config.spacing)


@_register("clay")
class ClayShowcaseEnv(clay.ClayHolder, ShowcaseEnv):
    """A 6 cm clay ball on the table beside a wooden weight; plastic after every control step."""

    SHOWCASE_TITLE = "Clay: 6 cm ball, lattice of springs that yield"
    clay_xy = (0.05, -0.05)
    weight_half_size = (0.03, 0.03, 0.015)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.load_clay(clay.clay_ball(0.03, self.clay_config.spacing))
        self.weight = _build_box(self.scene, "weight", self.weight_half_size, (0.6, 0.45, 0.3, 1))

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            origin = torch.tensor([[self.clay_xy[0], self.clay_xy[1], self.clay_config.radius]]).repeat(b, 1)
            self.clay.reset(env_idx, origin)
            self.weight.set_pose(Pose.create_from_pq(torch.tensor([[0.05, 0.12, self.weight_half_size[2]]]).repeat(b, 1)))

    def deformable_points(self):
        return self.clay.positions()

    def evaluate(self):
        points = self.clay.positions()
        r = self.clay_config.radius
        return dict(
            height=clay.height(points, r),
            footprint_area=metrics.footprint_area(points, self.clay_config.spacing),
            width_x=clay.width_along(points, torch.tensor([1.0, 0.0], device=self.device), r),
        )


class PourShowcaseEnv(ShowcaseEnv):
    """A full source container beside an empty target container; subclasses pick media and vessels."""

    particle_config: particles.ParticleConfig
    source_shape: containers.ContainerShape
    target_shape: containers.ContainerShape
    source_xy = (0.08, -0.12)
    target_xy = (0.08, 0.12)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.source = containers.build_container(self.scene, "source", self.source_shape, color=(0.9, 0.9, 0.92, 1))
        self.target = containers.build_container(self.scene, "target", self.target_shape, color=(0.85, 0.75, 0.55, 1))
        self.particles = particles.build_particles(self.scene, "particles", self.particle_config)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            for actor, xy in ((self.source, self.source_xy), (self.target, self.target_xy)):
                actor.set_pose(Pose.create_from_pq(torch.tensor([[xy[0], xy[1], 0.0]]).repeat(b, 1)))
            particles.fill_upright(self.particles, self.source_shape,
                                   torch.tensor([[self.source_xy[0], self.source_xy[1], 0.0]]).repeat(b, 1))

    def deformable_points(self):
        return self.particles.positions()

    def evaluate(self):
        p = self.particles.positions()
        return dict(
            in_source=particles.fraction_inside(p, self.source.pose, self.source_shape),
            in_target=particles.fraction_inside(p, self.target.pose, self.target_shape),
            spilled=particles.fraction_spilled(p, [(self.source.pose, self.source_shape), (self.target.pose, self.target_shape)]),
        )


@_register("liquid")
class LiquidShowcaseEnv(PourShowcaseEnv):
    """100 low-friction spheres (water) in a pitcher with a spout, beside an empty glass."""

    SHOWCASE_TITLE = "Liquid: 100 low-friction spheres in a pitcher, glass beside"
    particle_config = particles.LIQUID
    source_shape = containers.pitcher(height=0.09)
    target_shape = containers.glass()


@_register("granular")
class GranularShowcaseEnv(PourShowcaseEnv):
    """100 high-friction spheres (beans) in a cup, beside an empty bowl and a scoop."""

    SHOWCASE_TITLE = "Granular: 100 high-friction beans in a cup, bowl and scoop beside"
    particle_config = particles.GRANULAR
    source_shape = containers.cup(radius=0.04, height=0.09)
    target_shape = containers.bowl()

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.scoop = containers.build_container(self.scene, "scoop", containers.scoop(), color=(0.4, 0.6, 0.8, 1))

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            self.scoop.set_pose(Pose.create_from_pq(torch.tensor([[0.2, 0.0, 0.0]]).repeat(b, 1), yaw_quat(torch.full((b,), np.pi / 2))))


def render_showcase(kind: str, out: Path, seed: int = 0, settle_steps: int = 20, size: int = 256) -> Path:
    """Save one PNG with every camera of the `kind` showcase after `settle_steps` of a still robot."""
    import gymnasium as gym

    from maniladder_ms.render import camera_images, save_tiled

    env = gym.make(SHOWCASE_ENV_IDS[kind], obs_mode="rgb", control_mode="pd_joint_delta_pos",
                   sensor_configs=dict(width=size, height=size))
    try:
        env.reset(seed=seed)
        still = torch.zeros(env.action_space.shape)
        still[..., -1] = 1  # gripper open
        for _ in range(settle_steps):
            env.step(still)
        title = f"{env.unwrapped.SHOWCASE_TITLE}  (seed {seed}, after {settle_steps} steps)"
        return save_tiled(camera_images(env), title, out)
    finally:
        env.close()
