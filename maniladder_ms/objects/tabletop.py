"""Small rigid table-top objects made from primitives: pen, trays, upright cylinder, flat boxes (a card, a stand),
shelf, a tray raised on a stand, ping-pong ball, a U-shaped channel, a standing ring."""

from __future__ import annotations

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

from maniladder_ms.deformables import metrics
from maniladder_ms.geometry import yaw_of

WOOD_DENSITY = 600.0


def build_pen(
    scene: ManiSkillScene, name: str, length: float, radius: float, body_color, cap_color
) -> "Actor":
    """A pen lying along its local x axis: capsule collision, cylinder body and a coloured cap."""
    builder = scene.create_actor_builder()
    half = length / 2 - radius
    builder.add_capsule_collision(radius=radius, half_length=half, density=WOOD_DENSITY)
    body = sapien.render.RenderMaterial(base_color=list(body_color), roughness=0.4)
    cap = sapien.render.RenderMaterial(base_color=list(cap_color), roughness=0.4)
    cap_len = 0.2 * length
    builder.add_cylinder_visual(
        pose=sapien.Pose(p=[-cap_len / 2, 0, 0]), radius=radius, half_length=half - cap_len / 2, material=body
    )
    builder.add_cylinder_visual(
        pose=sapien.Pose(p=[half - cap_len / 2, 0, 0]), radius=radius * 1.08, half_length=cap_len / 2, material=cap
    )
    builder.add_sphere_visual(pose=sapien.Pose(p=[half, 0, 0]), radius=radius * 1.08, material=cap)
    builder.add_sphere_visual(pose=sapien.Pose(p=[-half, 0, 0]), radius=radius, material=body)
    builder.initial_pose = sapien.Pose(p=[0, 0, radius])
    return builder.build(name=name)


def build_tray(
    scene: ManiSkillScene, name: str, inner_half_size: tuple[float, float], wall_height: float,
    wall_thickness: float, base_thickness: float, color,
) -> "Actor":
    """An open rectangular tray (base plate + four walls) with its long side along local x.

    The actor origin is the centre of the base plate's bottom face, so it rests on the table at z = 0.
    """
    parts = open_box_parts(inner_half_size, wall_height, wall_thickness, base_thickness)
    return boxes_builder(scene, parts, color, density=WOOD_DENSITY).build(name=name)


def boxes_builder(scene: ManiSkillScene, parts, color, density: float = 1000.0):
    """An actor builder (origin at the identity pose) of the (centre, half size) boxes `parts` in one colour."""
    builder = scene.create_actor_builder()
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.6)
    for centre, half in parts:
        builder.add_box_collision(pose=sapien.Pose(p=centre), half_size=half, density=density)
        builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half, material=mat)
    builder.initial_pose = sapien.Pose()
    return builder


def open_box_parts(inner_half_size: tuple[float, float], wall_height: float, wall_thickness: float,
                   base_thickness: float) -> list[tuple[list[float], list[float]]]:
    """(centre, half size) boxes of an open box standing on z = 0: base plate, walls at +-x, walls at +-y."""
    ix, iy = inner_half_size
    t = wall_thickness
    return [
        ([0, 0, base_thickness / 2], [ix + t, iy + t, base_thickness / 2]),
        ([ix + t / 2, 0, wall_height / 2], [t / 2, iy + t, wall_height / 2]),
        ([-ix - t / 2, 0, wall_height / 2], [t / 2, iy + t, wall_height / 2]),
        ([0, iy + t / 2, wall_height / 2], [ix, t / 2, wall_height / 2]),
        ([0, -iy - t / 2, wall_height / 2], [ix, t / 2, wall_height / 2]),
    ]


def build_raised_tray(
    scene: ManiSkillScene, name: str, inner_half_size: tuple[float, float], wall_height: float, lip_height: float,
    wall_thickness: float, floor_height: float, color, overhang: float = 0.0, slab: float = 0.01,
) -> "Actor":
    """A fixed (kinematic) tray on a solid stand: its floor's top face `floor_height` above the table, walls
    `wall_height` high round it except at -y, where a lip only `lip_height` high lets a hand slide in over it.
    `overhang` > 0: the floor is a `slab` thick plate whose -y edge (the lip's outer face) overhangs the stand by
    `overhang` (the stand's -y face that far behind it: a ledge a hand can reach under). The actor origin is on
    the table under the floor's centre."""
    stand, *walls = open_box_parts(inner_half_size, wall_height, wall_thickness, floor_height)  # the stand: a base
    parts = [stand]
    if overhang > 0:
        (x, y, _), (hx, hy, _) = stand
        under = floor_height - slab  # the stand's top: the slab lies on it
        parts = [([x, y, floor_height - slab / 2], [hx, hy, slab / 2]),
                 ([x, y + overhang / 2, under / 2], [hx, hy - overhang / 2, under / 2])]
    for (x, y, z), (hx, hy, hz) in walls:
        if y < 0:  # the -y wall: the lip
            z = hz = lip_height / 2
        parts.append(([x, y, z + floor_height], [hx, hy, hz]))
    return boxes_builder(scene, parts, color).build_kinematic(name=name)


def build_upright_cylinder(scene: ManiSkillScene, name: str, radius: float, half_height: float, density: float,
                           color, kinematic: bool = False) -> "Actor":
    """A cylinder standing on z = 0 (a can, a peg, a weight); its origin is its centre. `kinematic`: a fixture
    (a post fixed to the table)."""
    builder = scene.create_actor_builder()
    upright = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])  # SAPIEN cylinders lie along x
    builder.add_cylinder_collision(upright, radius=radius, half_length=half_height, density=density)
    if scene.can_render():
        material = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
        builder.add_cylinder_visual(upright, radius=radius, half_length=half_height, material=material)
    builder.initial_pose = sapien.Pose(p=[0, 0, half_height])
    return builder.build_kinematic(name=name) if kinematic else builder.build(name=name)


def build_flat_box(scene: ManiSkillScene, name: str, half_size, color, density: float = WOOD_DENSITY,
                   friction: float | None = None, kinematic: bool = False) -> "Actor":
    """A box lying flat on z = 0 (a thin card, a low stand); its origin is its centre. `friction`: static and
    dynamic friction of its surface (None: SAPIEN's default material); `kinematic`: a fixture."""
    builder = scene.create_actor_builder()
    material = None if friction is None else physx.PhysxMaterial(friction, friction, 0.0)
    builder.add_box_collision(half_size=list(half_size), material=material, density=density)
    if scene.can_render():
        builder.add_box_visual(half_size=list(half_size),
                               material=sapien.render.RenderMaterial(base_color=list(color), roughness=0.5))
    builder.initial_pose = sapien.Pose(p=[0, 0, half_size[2]])
    return builder.build_kinematic(name=name) if kinematic else builder.build(name=name)


def build_shelf(scene: ManiSkillScene, name: str, top_half: tuple[float, float], height: float, color,
                board: float = 0.02, panel: float = 0.02) -> "Actor":
    """A fixed (kinematic) shelf standing on the table: a board `top_half` (x, y) half size, its top face
    `height` above the table, on two side panels under its +-y ends; open in front, behind and underneath.
    The actor origin is on the table under the board's centre."""
    hx, hy = top_half
    parts = [([0, 0, height - board / 2], [hx, hy, board / 2])]
    legs = (height - board) / 2
    parts += [([0, sign * (hy - panel / 2), legs], [hx, panel / 2, legs]) for sign in (1, -1)]
    builder = scene.create_actor_builder()
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.7) if scene.can_render() else None
    for centre, half in parts:
        builder.add_box_collision(sapien.Pose(p=centre), half_size=half)
        if mat is not None:
            builder.add_box_visual(sapien.Pose(p=centre), half_size=half, material=mat)
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)


def serving_tray_parts(inner_half_size: tuple[float, float], rim_height: float, end_height: float, wall_thickness: float,
                       base_thickness: float) -> list[tuple[list[float], list[float]]]:
    """(centre, half size) boxes of a serving tray standing on z = 0: base plate, low rims along its +-x sides
    (`rim_height`), tall end walls at +-y (`end_height`, the parts two hands take)."""
    ix, iy = inner_half_size
    t = wall_thickness
    return [
        ([0, 0, base_thickness / 2], [ix + t, iy + t, base_thickness / 2]),
        *[([sign * (ix + t / 2), 0, rim_height / 2], [t / 2, iy, rim_height / 2]) for sign in (1, -1)],
        *[([0, sign * (iy + t / 2), end_height / 2], [ix + t, t / 2, end_height / 2]) for sign in (1, -1)],
    ]


def build_serving_tray(scene: ManiSkillScene, name: str, inner_half_size: tuple[float, float], rim_height: float,
                       end_height: float, wall_thickness: float, base_thickness: float, color,
                       density: float = WOOD_DENSITY) -> "Actor":
    """A serving tray (`serving_tray_parts`) as a dynamic actor; its origin is the centre of its bottom face."""
    builder = scene.create_actor_builder()
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5) if scene.can_render() else None
    for centre, half in serving_tray_parts(inner_half_size, rim_height, end_height, wall_thickness, base_thickness):
        builder.add_box_collision(pose=sapien.Pose(p=centre), half_size=half, density=density)
        if mat is not None:
            builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half, material=mat)
    builder.initial_pose = sapien.Pose()
    return builder.build(name=name)


def build_ping_pong_ball(scene: ManiSkillScene, name: str, radius: float, mass: float, color,
                         friction: float = 0.5, restitution: float = 0.8) -> "Actor":
    """A hollow ball (a thin shell: inertia 2/3 m r^2) of `mass` kg; its origin is its centre."""
    builder = scene.create_actor_builder()
    builder.add_sphere_collision(radius=radius, material=physx.PhysxMaterial(friction, friction, restitution))
    inertia = 2 / 3 * mass * radius**2
    builder.set_mass_and_inertia(mass, sapien.Pose(), [inertia] * 3)
    if scene.can_render():
        builder.add_sphere_visual(radius=radius, material=sapien.render.RenderMaterial(base_color=list(color),
                                                                                      roughness=0.3))
    builder.initial_pose = sapien.Pose(p=[0, 0, radius])
    return builder.build(name=name)


def build_channel(scene: ManiSkillScene, name: str, inner_width: float, depth: float, length: float, wall: float,
                  floor: float, color, floor_color=None) -> "Actor":
    """A fixed (kinematic) U-shaped channel lying on the table along its local x axis: a floor plate `floor`
    thick and two walls `wall` thick rising `depth` above it, `inner_width` apart, both `length` long; open at
    both ends and on top. Its origin is the middle of the plate's bottom face (on the table at z = 0), so the
    channel's floor lies at z = `floor` and its walls' top at `floor` + `depth`. `floor_color`: the plate's
    colour between the walls (default `color`)."""
    builder = scene.create_actor_builder()
    outer = inner_width / 2 + wall
    parts = [([0, 0, floor / 2], [length / 2, outer, floor / 2], floor_color or color)]
    for sign in (1, -1):
        parts.append(([0, sign * (inner_width / 2 + wall / 2), floor + depth / 2], [length / 2, wall / 2, depth / 2],
                      color))
    for centre, half, part_color in parts:
        builder.add_box_collision(pose=sapien.Pose(p=centre), half_size=half)
        if scene.can_render():
            builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half,
                                   material=sapien.render.RenderMaterial(base_color=list(part_color), roughness=0.6))
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)


class Channel:
    """A U-shaped channel fixed to the table (`build_channel`, its actor in `actor`) and what a task asks of it
    (RopeIntoGroove's groove, CableIntoClipHand's clip): its axis, its walls' top, the share of points inside
    (`metrics.inside_channel_fraction`), how far points lie off its axis."""

    def __init__(self, scene: ManiSkillScene, name: str, inner_width: float, depth: float, length: float, wall: float,
                 floor: float, color, floor_color=None):
        self.actor = build_channel(scene, name, inner_width, depth, length, wall, floor, color, floor_color)
        self.half_width, self.half_length = inner_width / 2, length / 2
        self.top = floor + depth  # the walls' top above the table

    @property
    def pose(self):
        return self.actor.pose

    def set_pose(self, pose):
        self.actor.set_pose(pose)

    def axis(self) -> torch.Tensor:
        """Yaw of the channel's axis (its local x), [B]."""
        return yaw_of(self.actor.pose.q)

    def inside_fraction(self, points: torch.Tensor) -> torch.Tensor:
        """Share of `points` [B, N, 3] inside the channel: between its walls and its ends, below the walls' top; [B]."""
        return metrics.inside_channel_fraction(points, self.actor.pose.p, self.axis(), self.half_width,
                                               self.half_length, self.top)

    def off_axis(self, points: torch.Tensor) -> torch.Tensor:
        """Top-down distance of `points` [B, N, 2+] from the channel's axis line, [B, N]."""
        return metrics.channel_coords(points, self.actor.pose.p, self.axis())[1].abs()


def place_at_rest(actor, pose):
    """Put a dynamic actor at `pose` (a batched Pose) with zero linear and angular velocity: where a reset places
    a free object, so it does not carry the last episode's motion into the next."""
    actor.set_pose(pose)
    actor.set_linear_velocity(pose.p.new_zeros(pose.p.shape))
    actor.set_angular_velocity(pose.p.new_zeros(pose.p.shape))


def build_towel_bar(scene: ManiSkillScene, name: str, top_height: float, bar_radius: float, half_length: float,
                    color, post_radius: float = 0.012, friction: float = 1.0) -> "Actor":
    """A fixed (kinematic) towel bar: a horizontal round rod along y, its top `top_height` above the table,
    `half_length` to each side of its middle, on two upright posts under its ends (each on a thin foot plate).
    The actor origin is on the table under the rod's middle. `friction`: static and dynamic, of its surface."""
    builder = scene.create_actor_builder()
    material = physx.PhysxMaterial(friction, friction, 0.0)
    along_y = sapien.Pose(q=[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])  # SAPIEN cylinders lie along x
    along_z = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
    axis_height = top_height - bar_radius
    cylinders = [(sapien.Pose(p=[0, 0, axis_height]) * along_y, bar_radius, half_length + post_radius)]
    cylinders += [(sapien.Pose(p=[0, sign * half_length, axis_height / 2]) * along_z, post_radius, axis_height / 2)
                  for sign in (1, -1)]
    feet = [(sapien.Pose(p=[0, sign * half_length, 0.004]), [0.03, 0.03, 0.004]) for sign in (1, -1)]
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.4) if scene.can_render() else None
    for pose, radius, half in cylinders:
        builder.add_cylinder_collision(pose, radius=radius, half_length=half, material=material)
        if mat is not None:
            builder.add_cylinder_visual(pose, radius=radius, half_length=half, material=mat)
    for pose, half in feet:
        builder.add_box_collision(pose, half_size=half, material=material)
        if mat is not None:
            builder.add_box_visual(pose, half_size=half, material=mat)
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)


def build_standing_ring(scene: ManiSkillScene, name: str, inner_radius: float, tube_radius: float, centre_height: float,
                        color, pieces: int = 16, post_half: tuple[float, float] = (0.008, 0.008)) -> "Actor":
    """A fixed (kinematic) ring standing upright on a post: `pieces` capsules round a circle in the local x-z plane
    (the ring's axis is the local y axis), their inner surface `inner_radius` from the centre, which stands
    `centre_height` above the table; a square post (`post_half`: its x, y half sizes) from the table up to the
    ring's bottom. Its origin is on the table under the ring's centre."""
    builder = scene.create_actor_builder()
    mid = inner_radius + tube_radius  # the tube's centre line
    half = mid * np.sin(np.pi / pieces)  # each capsule spans one chord of the centre line
    chord = mid * np.cos(np.pi / pieces)  # distance from the centre to each chord's middle
    material = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5) if scene.can_render() else None
    for k in range(pieces):
        a = 2 * np.pi * (k + 0.5) / pieces
        # the chord's middle, its axis along the tangent (local x turned about y by the angle)
        pose = sapien.Pose(p=[chord * np.cos(a), 0, centre_height + chord * np.sin(a)],
                           q=[np.cos((a + np.pi / 2) / -2), 0, np.sin((a + np.pi / 2) / -2), 0])
        builder.add_capsule_collision(pose, radius=tube_radius, half_length=half)
        if material is not None:
            builder.add_capsule_visual(pose, radius=tube_radius, half_length=half, material=material)
    post_height = centre_height - mid - tube_radius * 0.5
    if post_height > 0:
        post = sapien.Pose(p=[0, 0, post_height / 2])
        size = [post_half[0], post_half[1], post_height / 2]
        builder.add_box_collision(post, half_size=size)
        if material is not None:
            builder.add_box_visual(post, half_size=size, material=material)
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)


def wall_hook_axis(tilt: float) -> tuple[float, float, float]:
    """The direction `build_wall_hook`'s shaft points (out of its board, towards the tip) in the hook's frame."""
    return (-float(np.cos(tilt)), 0.0, float(np.sin(tilt)))


def build_wall_hook(scene: ManiSkillScene, name: str, shaft_length: float, shaft_radius: float, tilt: float,
                    board_half: tuple[float, float], board_span: tuple[float, float], color, knob_radius: float = 0.0,
                    friction: float = 1.0) -> "Actor":
    """A fixed (kinematic) wall hook: a straight round shaft `shaft_length` long and of radius `shaft_radius`,
    sticking out of the front face (towards -x) of an upright board, pitched `tilt` rad up from -x (its axis
    (-cos tilt, 0, sin tilt), `wall_hook_axis`), and ending in a ball `knob_radius` (0: none) at its tip. The
    actor origin is the shaft's root (on the board's front face, on its axis); the tip's centre is at
    `shaft_length` times the axis. The board (`board_half`: its x, y half sizes) spans `board_span` =
    (below, above) the shaft's axis: placed with its bottom in the table, it stands on it."""
    builder = scene.create_actor_builder()
    material = physx.PhysxMaterial(friction, friction, 0.0)
    mat = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5) if scene.can_render() else None
    below, above = board_span
    board_size = [board_half[0], board_half[1], (below + above) / 2]
    board = sapien.Pose(p=[board_half[0], 0, (above - below) / 2])
    axis = np.asarray(wall_hook_axis(tilt))
    # SAPIEN cylinders lie along x: turned about y by the tilt, along the shaft's axis
    shaft = sapien.Pose(p=axis * shaft_length / 2, q=[np.cos(tilt / 2), 0, np.sin(tilt / 2), 0])
    knob = sapien.Pose(p=axis * shaft_length)
    builder.add_box_collision(board, half_size=board_size, material=material)
    builder.add_cylinder_collision(shaft, radius=shaft_radius, half_length=shaft_length / 2, material=material)
    if knob_radius:
        builder.add_sphere_collision(knob, radius=knob_radius, material=material)
    if mat is not None:
        builder.add_box_visual(board, half_size=board_size, material=mat)
        builder.add_cylinder_visual(shaft, radius=shaft_radius, half_length=shaft_length / 2, material=mat)
        if knob_radius:
            builder.add_sphere_visual(knob, radius=knob_radius, material=mat)
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)
