"""A mug: a straight cup (revolved wall, CoACD collision, `objects.containers`) with a loop handle.

The handle is a C of three boxes on the mug's -x side: two arms out from the wall and an outer bar,
leaving an opening a peg or a finger passes through along the mug's y axis. HangMug hangs it by
that loop; later levels reuse it (PlaceMugOnCoasterHand, HandoverMugHands), with the round coaster
they set it on (`build_coaster`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

from .containers import CERAMIC_DENSITY, ContainerShape, body_builder, build_resting, cup
from maniladder_ms.geometry import tilt
from .pot import build_stove_plate

COASTER_RADIUS, COASTER_HEIGHT = 0.055, 0.005  # an 11 cm cork coaster, 5 mm thick
# ceramic-like mass without ceramic density: ~0.13 kg for the ManiLadder mug shapes, light enough that a rim
# pinch or a LEAP grasp holds it without it tilting in the fingers
MUG_DENSITY = 800.0
RIM_DEPTH = 0.025  # a rim pinch closes this far below the rim, one finger inside the wall and one outside


@dataclass(frozen=True)
class MugShape:
    body: ContainerShape = cup(radius=0.037, height=0.09, wall=0.005, floor=0.006)
    opening: tuple[float, float] = (0.028, 0.05)  # radial width and height of the loop's opening
    bar: float = 0.01  # thickness of the arms and the outer bar (x / z)
    width: float = 0.014  # handle thickness along y

    @property
    def outer_radius(self) -> float:
        return self.body.rim_radius + self.body.wall

    def opening_centre(self) -> np.ndarray:
        """Centre of the loop's opening in the mug frame (origin at the bottom centre)."""
        return np.array([-(self.outer_radius + self.opening[0] / 2), 0.0, self.body.height / 2])

    def handle_boxes(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) of the two arms and the outer bar; the arms reach 3 mm into the wall."""
        cx, _, cz = self.opening_centre()
        w, h = self.opening
        arm_len = w + self.bar + 0.003
        arm_x = -(self.outer_radius - 0.003 + arm_len / 2)
        half_arm = [arm_len / 2, self.width / 2, self.bar / 2]
        return [
            ([arm_x, 0.0, cz + h / 2 + self.bar / 2], half_arm),
            ([arm_x, 0.0, cz - h / 2 - self.bar / 2], half_arm),
            ([cx - w / 2 - self.bar / 2, 0.0, cz], [self.bar / 2, self.width / 2, h / 2 + self.bar]),
        ]


def build_mug(scene: ManiSkillScene, name: str, shape: MugShape, color, friction: float = 0.8,
              density: float = CERAMIC_DENSITY):
    """The mug as a dynamic actor standing on z = 0."""
    builder, material, render_mat = body_builder(scene, shape.body, color, density, friction)
    for centre, half in shape.handle_boxes():
        builder.add_box_collision(sapien.Pose(p=centre), half_size=half, material=material, density=density)
        if render_mat is not None:
            builder.add_box_visual(sapien.Pose(p=centre), half_size=half, material=render_mat)
    return build_resting(builder, name)


def build_coaster(scene: ManiSkillScene, name: str, color=(0.72, 0.55, 0.36, 1), ring_color=(0.45, 0.3, 0.18, 1)):
    """A round coaster (`COASTER_RADIUS`, `COASTER_HEIGHT`) fixed to the table (kinematic: tasks place it per
    episode), its origin at its bottom centre: a disc with a darker rim ring (`pot.build_stove_plate`)."""
    return build_stove_plate(scene, name, COASTER_RADIUS, COASTER_HEIGHT, color=color, ring_color=ring_color)


def build_mug_tree(scene: ManiSkillScene, name: str, post_height: float, peg_height: float, peg_length: float,
                   peg_radius: float, color):
    """A fixed (kinematic) stand: a post on z = 0 with one horizontal peg sticking out along +y at `peg_height`;
    the actor origin is the post's foot."""
    builder = scene.create_actor_builder()
    along_z = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])  # SAPIEN cylinders lie along x
    along_y = sapien.Pose(q=[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])
    base = (sapien.Pose(p=[0, 0, 0.005]), [0.05, 0.05, 0.005])
    builder.add_box_collision(base[0], half_size=base[1])
    post = sapien.Pose(p=[0, 0, post_height / 2]) * along_z
    builder.add_cylinder_collision(post, radius=0.012, half_length=post_height / 2)
    peg = sapien.Pose(p=[0, peg_length / 2, peg_height]) * along_y
    builder.add_cylinder_collision(peg, radius=peg_radius, half_length=peg_length / 2)
    if scene.can_render():
        mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.6)
        builder.add_box_visual(base[0], half_size=base[1], material=mat)
        builder.add_cylinder_visual(post, radius=0.012, half_length=post_height / 2, material=mat)
        builder.add_cylinder_visual(peg, radius=peg_radius, half_length=peg_length / 2, material=mat)
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)


def rim_point(mug, shape: MugShape, depth: float = RIM_DEPTH) -> torch.Tensor:
    """World point in the middle of the wall on the side opposite the handle (the mug's +x), `depth` below the rim,
    (num_envs, 3): where a rim pinch closes."""
    from mani_skill.utils.structs.pose import Pose

    local = torch.tensor([[shape.outer_radius - shape.body.wall / 2, 0.0, shape.body.height - depth]],
                         device=mug.pose.p.device)
    return (mug.pose * Pose.create_from_pq(local.expand(len(mug.pose.p), 3))).p


def mug_body_centre(mug, shape: MugShape) -> torch.Tensor:
    """World centre of a mug's body (half its height up its axis from its bottom-centre origin), (num_envs, 3)."""
    from mani_skill.utils.geometry.rotation_conversions import quaternion_apply

    half = torch.zeros_like(mug.pose.p)
    half[:, 2] = shape.body.height / 2
    return mug.pose.p + quaternion_apply(mug.pose.q, half)


def placed_on_coaster(mug, coaster, max_tilt_deg: float, centre_tol: float, rest_tol: float, info: dict) -> torch.Tensor:
    """Whether a mug stands on a coaster (`build_coaster`): upright within `max_tilt_deg`, its bottom centre within
    `centre_tol` (horizontally) of the coaster's centre and within `rest_tol` of the coaster's top. Writes `tilt`,
    `is_upright`, `is_centred`, `on_coaster` into `info`."""
    offset = mug.pose.p - coaster.pose.p  # bottom centre from the coaster's bottom centre
    info["tilt"] = tilt(mug)
    info["is_upright"] = info["tilt"] < np.deg2rad(max_tilt_deg)
    info["is_centred"] = torch.linalg.norm(offset[:, :2], dim=1) <= centre_tol
    info["on_coaster"] = (offset[:, 2] - COASTER_HEIGHT).abs() <= rest_tol
    return info["is_upright"] & info["is_centred"] & info["on_coaster"]
