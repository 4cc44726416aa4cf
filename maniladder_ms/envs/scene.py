"""The ManiLadder table-top scene: table, floor, backdrop, lighting and distractors.

Without domain randomisation the scene is fixed (plain wood table, grey backdrop, fixed lights, no
distractors). With it, each reconfiguration draws a procedural table and backdrop texture, lighting
(ambient level, key-light direction and colour) and 0-3 distractor objects; distractors are placed
at every episode reset on the table outside the task's region and the robot's base.

Every visual draw (textures, lighting, distractor count, shapes, colours and places) comes from the
scene's own generators, seeded by the *visual seed* alone; none touches the episode RNGs (torch's global
RNG, `_batched_episode_rng`) the task draws its layout from. A seed hence gives the same task layout with
and without randomisation, and a new visual seed gives the same episode a new look.
"""

from __future__ import annotations

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.utils.building.ground import build_ground
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import yaw_quat

from .textures import texture_files

TABLE_HALF_SIZE = (0.6, 0.7, 0.4)  # x (depth, away from the robot), y (width), z (height) in metres
TABLE_CENTER_X = -0.15  # the robot base stands on the table top at x = -0.615, as in ManiSkill
BACKDROP_DISTANCE = 1.6
MAX_DISTRACTORS = 3
DISTRACTOR_HALF_SIZE = (0.015, 0.03)  # range of distractor half-extent
DISTRACTOR_REACH = float(np.sqrt(2) * DISTRACTOR_HALF_SIZE[1])  # farthest a distractor reaches from its centre in xy
# distractor centres stay this far outside the task's region: a distractor reaches no closer to it than
# KEEP_OUT_MARGIN - DISTRACTOR_REACH, the room a task's objects may overhang their TASK_REGION by at reset
KEEP_OUT_MARGIN = 0.05
DISTRACTOR_AREA = (-0.35, 0.35, -0.45, 0.45)  # (xmin, xmax, ymin, ymax) distractor centres are drawn in
DEFAULT_TABLE_COLOR = (0.62, 0.47, 0.32, 1)
DEFAULT_BACKDROP_COLOR = (0.82, 0.82, 0.82, 1)


def _material(default_color, texture=None, roughness: float = 0.7) -> sapien.render.RenderMaterial:
    """The default plain material, or (randomising) `texture` with the drawn roughness."""
    mat = sapien.render.RenderMaterial(base_color=list(default_color), roughness=roughness, metallic=0.0)
    if texture is not None:
        mat.base_color_texture = sapien.render.RenderTexture2D(filename=str(texture), mipmap_levels=4)
        mat.base_color = [1, 1, 1, 1]
    return mat


class LadderScene:
    """Builds and resets the shared parts of every ManiLadder task scene."""

    def __init__(self, env, randomize: bool, visual_seed: int | None = None):
        self.env = env
        self.randomize = randomize
        self.visual_seed = visual_seed if randomize else None
        # the look: one draw per reconfiguration, shared by the parallel sub-scenes (same textures/lights/count)
        self._rng = np.random.RandomState(visual_seed) if randomize else None
        # the distractors' places at each episode reset (on the CPU: the same places on any sim device)
        self._placement = torch.Generator().manual_seed(visual_seed) if randomize else None
        self.distractors = []
        self.distractor_heights: list[float] = []
        # what the visual seed drew (texture names, roughness, distractors, lights); {} without randomisation
        self.look: dict = {"visual_seed": visual_seed} if randomize else {}

    def build(self):
        scene = self.env.scene
        rng = self._rng
        table = dict(texture=None, roughness=0.7)
        backdrop = dict(texture=None, roughness=0.7)
        if rng is not None:  # all drawn even without a renderer, so a visual seed gives the same scene either way
            textures = texture_files()
            table["texture"], backdrop["texture"] = (textures[i] for i in rng.choice(len(textures), 2, replace=False))
            table["roughness"], backdrop["roughness"] = float(rng.uniform(0.3, 0.9)), float(rng.uniform(0.3, 0.9))
            self.look.update(table_texture=table["texture"].name, table_roughness=table["roughness"],
                             backdrop_texture=backdrop["texture"].name, backdrop_roughness=backdrop["roughness"])
        hx, hy, hz = TABLE_HALF_SIZE
        builder = scene.create_actor_builder()
        builder.add_box_collision(half_size=[hx, hy, hz])
        if scene.can_render():
            builder.add_box_visual(half_size=[hx, hy, hz], material=_material(DEFAULT_TABLE_COLOR, **table))
        builder.initial_pose = sapien.Pose(p=[TABLE_CENTER_X, 0, -hz])
        self.table = builder.build_kinematic(name="table")
        self.ground = build_ground(scene, altitude=-2 * hz)
        if scene.can_render():
            self._build_backdrop(_material(DEFAULT_BACKDROP_COLOR, **backdrop))
        n = 0 if rng is None else int(rng.randint(0, MAX_DISTRACTORS + 1))
        if rng is not None:
            self.look["distractors"] = []
        built = [self._build_distractor(i, rng) for i in range(n)]
        self.distractors = [actor for actor, _ in built]
        self.distractor_heights = [height for _, height in built]

    def _build_backdrop(self, mat: sapien.render.RenderMaterial):
        # Four walls around the table so every third-view camera sees a controlled background.
        builder = self.env.scene.create_actor_builder()
        d = BACKDROP_DISTANCE
        for centre, half in (
            ([TABLE_CENTER_X + d, 0, 0.2], [0.01, d, 1.5]),
            ([TABLE_CENTER_X - d, 0, 0.2], [0.01, d, 1.5]),
            ([TABLE_CENTER_X, d, 0.2], [d, 0.01, 1.5]),
            ([TABLE_CENTER_X, -d, 0.2], [d, 0.01, 1.5]),
        ):
            builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half, material=mat)
        builder.initial_pose = sapien.Pose()
        self.backdrop = builder.build_static(name="backdrop")

    def _build_distractor(self, i: int, rng: np.random.RandomState):
        builder = self.env.scene.create_actor_builder()
        half = rng.uniform(*DISTRACTOR_HALF_SIZE, size=3)
        color = list(rng.uniform(0.1, 0.95, 3)) + [1]
        mat = sapien.render.RenderMaterial(base_color=color, roughness=0.6)
        kind = rng.randint(3)
        self.look["distractors"].append(
            dict(shape=("box", "cylinder", "sphere")[kind], half_size=half.tolist(), color=color[:3]))
        if kind == 0:
            builder.add_box_collision(half_size=half)
            builder.add_box_visual(half_size=half, material=mat)
            height = half[2]
        elif kind == 1:
            # capsule/cylinder axes are x in SAPIEN: stand the cylinder upright
            up = sapien.Pose(q=[0.7071068, 0, 0.7071068, 0])
            builder.add_cylinder_collision(pose=up, radius=half[0], half_length=half[2])
            builder.add_cylinder_visual(pose=up, radius=half[0], half_length=half[2], material=mat)
            height = half[2]
        else:
            builder.add_sphere_collision(radius=half[0])
            builder.add_sphere_visual(radius=half[0], material=mat)
            height = half[0]
        builder.initial_pose = sapien.Pose(p=[0, 0, height])
        return builder.build(name=f"distractor_{i}"), float(height)

    def load_lighting(self):
        scene, rng = self.env.scene, self._rng
        if rng is None:
            scene.set_ambient_light([0.3, 0.3, 0.3])
            scene.add_directional_light([1, 1, -1], [1, 1, 1], shadow=self.env.enable_shadow, shadow_scale=5, shadow_map_size=2048)
            scene.add_directional_light([0, 0, -1], [1, 1, 1])
            return
        ambient = float(rng.uniform(0.15, 0.5))
        direction = [float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)), -1.0]
        warmth = rng.uniform(-0.15, 0.15)
        color = np.clip(rng.uniform(0.6, 1.3) * np.array([1 + warmth, 1, 1 - warmth]), 0, 2).tolist()
        top = float(rng.uniform(0.3, 0.9))
        self.look.update(ambient=ambient, key_light_direction=direction, key_light_color=color, top_light=top)
        scene.set_ambient_light([ambient] * 3)
        scene.add_directional_light(direction, color, shadow=self.env.enable_shadow, shadow_scale=5, shadow_map_size=2048)
        scene.add_directional_light([0, 0, -1], [top] * 3)

    def initialize(self, env_idx: torch.Tensor, keep_out: tuple[float, float, float, float]):
        """Place distractors on the table outside `keep_out` = (xmin, xmax, ymin, ymax)."""
        if not self.distractors:
            return
        b = len(env_idx)
        placed: list[torch.Tensor] = []
        for actor, height in zip(self.distractors, self.distractor_heights):
            xy = self._sample_clear_xy(b, keep_out, placed)
            placed.append(xy)
            xyz = torch.cat([xy, torch.full((b, 1), height, device="cpu")], dim=1)
            yaw = torch.rand(b, generator=self._placement, device="cpu") * 2 * np.pi
            actor.set_pose(Pose.create_from_pq(xyz.to(self.env.device), yaw_quat(yaw.to(self.env.device))))

    def _sample_clear_xy(self, b: int, keep_out, placed: list[torch.Tensor], tries: int = 64) -> torch.Tensor:
        """Rejection-sample b table positions outside keep_out (+margin), the robot base and earlier distractors."""
        margin = KEEP_OUT_MARGIN
        xmin, xmax, ymin, ymax = keep_out
        cpu = dict(device="cpu")
        ax0, ax1, ay0, ay1 = DISTRACTOR_AREA
        lo = torch.tensor([ax0, ay0], **cpu)
        hi = torch.tensor([ax1, ay1], **cpu)
        out = torch.zeros(b, 2, **cpu)
        todo = torch.ones(b, dtype=torch.bool, **cpu)
        robot = torch.tensor([-0.615, 0.0], **cpu)
        for _ in range(tries):
            cand = lo + torch.rand(b, 2, generator=self._placement, **cpu) * (hi - lo)
            inside_task = (
                (cand[:, 0] > xmin - margin) & (cand[:, 0] < xmax + margin)
                & (cand[:, 1] > ymin - margin) & (cand[:, 1] < ymax + margin)
            )
            near_robot = torch.linalg.norm(cand - robot, dim=1) < 0.3
            near_other = torch.zeros(b, dtype=torch.bool, **cpu)
            for xy in placed:
                near_other |= torch.linalg.norm(cand - xy, dim=1) < 2 * DISTRACTOR_REACH + 0.02
            ok = todo & ~inside_task & ~near_robot & ~near_other
            out[ok] = cand[ok]
            todo &= ~ok
            if not todo.any():
                return out
        raise RuntimeError("could not place distractors clear of the task region; the task region covers the table")
