"""Rope / cable: a chain of capsules as one articulation, with rope metrics.

SAPIEN's articulation builder has no spherical joint, so consecutive capsules are linked through a
small middle link by two revolute joints with perpendicular axes (one about the rope's local z, one
about its local y): the chain bends in every direction; twist about the rope axis is not modelled.
Bend stiffness and damping are the joint drives (target 0 = straight).

Metrics take the rope's points (`Rope.points()`, shape [B, n + 2, 3]: first tip, capsule centres,
last tip) so they also serve any other polyline:
- `end_to_end_distance`: distance between the two tips (m);
- `straightness`: end-to-end distance / arc length, 1 for a straight rope, smaller when bent or coiled;
- `winding_number`: signed turns of the rope about a vertical axis (wrap count around a peg/post);
- `through_ring`: whether the rope passes through a ring's disc, and how much of it lies on each side;
- `crossings` / `is_knotted`: self-crossings of the top-down projection and a knot test on them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.structs.articulation import Articulation
from mani_skill.utils.structs.link import Link
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.geometry import yaw_quat

# revolute joints turn about the x axis of their joint frame: these frames put that axis on z / y
X_TO_Z = sapien.Pose(q=[0.7071068, 0, -0.7071068, 0])
X_TO_Y = sapien.Pose(q=[0.7071068, 0, 0, 0.7071068])
# the middle link carries this fraction of a capsule's mass (PhysX needs a massive link; a light
# one keeps the chain's inertia on the capsules)
MIDDLE_LINK_MASS_FRACTION = 0.5
# SAPIEN skips contacts between shapes that share a bit of collision group 2 when their group 3
# (low 16 bits) is equal: rope capsules get their own group-3 id, so their group-2 bits only act
# among rope capsules, never against a robot's (which use the same bits for their own pairs)
ROPE_GROUP_ID = 0x2C0E
NEIGHBOUR_BITS = 32  # capsules i and i +- 31 share a bit too: ropes beyond 31 capsules miss those pairs


@dataclass(frozen=True)
class RopeConfig:
    """Parameters of a capsule-chain rope.

    length: total length (m), capsule tips included; radius: capsule radius (m), 8 mm pinches like a
    pen in the Panda gripper; segments: number of capsules (20-40 are cheap); bend_stiffness (N m/rad)
    and bend_damping (N m s/rad): drives of each joint towards straight; mass: total mass (kg);
    friction: static = dynamic friction of the capsules (high, so a gripper can hold a segment);
    max_bend: joint limit (rad) of each of the two joints between capsules.

    What lets a gripper hold the rope without the chain blowing up (measured with a Panda picking a
    capsule near the end and holding it 15 cm up for 60 steps, 20/20 seeds; before: 1/8 held, 1/8 NaN):
    armature (kg m^2) on every bend joint, ~60x a capsule's own inertia: a pinched capsule's hanging
    neighbour then no longer gets flung when it touches the finger pads; max_joint_velocity (rad/s)
    caps the bend speed, so a pinch across a joint (two capsules in one grasp) cannot pump energy into
    the chain; max_depenetration_velocity (m/s) caps how fast a capsule pressed into the table is
    pushed out, and 1 m/s is high enough that closing fingers meet a firm capsule instead of sinking
    through it (the old 0.3 m/s let them close to zero on it); solver_position_iterations of the rope
    articulation (PhysX takes the highest count in a touching group, so the gripper gets them too):
    at ManiSkill's 15 the pinched capsule was only loosely held (fingers sank 3 mm into it each, and
    one of two dual-arm grippers closed right through it), at 40 the fingers stop on its surface.
    """

    length: float = 0.4
    radius: float = 0.008
    segments: int = 20
    bend_stiffness: float = 0.002
    bend_damping: float = 0.001
    mass: float = 0.1
    friction: float = 1.0
    max_bend: float = 2.4
    armature: float = 1e-5
    max_joint_velocity: float = 20.0
    max_depenetration_velocity: float = 1.0
    solver_position_iterations: int = 40
    color: tuple = (0.85, 0.3, 0.15, 1)
    end_color: tuple = (0.25, 0.25, 0.3, 1)

    @property
    def segment_length(self) -> float:
        return self.length / self.segments


class Rope:
    """A built rope: `articulation` (ManiSkill, batched over envs), its capsule `links` in order and
    `capsules`, one merged view of them (one pose query for the whole rope)."""

    def __init__(self, articulation: Articulation, config: RopeConfig):
        self.articulation = articulation
        self.config = config
        self.links = [articulation.links_map[f"capsule_{i}"] for i in range(config.segments)]
        self.capsules = _merge_bodies(self.links, f"{articulation.name}_capsules")

    def points(self) -> torch.Tensor:
        """The rope as a polyline: first tip, capsule centres, last tip; [B, segments + 2, 3]."""
        pose = self.capsules.pose  # capsule-major: [segments * B]
        n = self.config.segments
        p = pose.p.reshape(n, -1, 3).transpose(0, 1)
        q = pose.q.reshape(n, -1, 4).transpose(0, 1)
        half = self.config.segment_length / 2
        tip0 = p[:, 0] - half * segment_axis(q[:, 0])
        tip1 = p[:, -1] + half * segment_axis(q[:, -1])
        return torch.cat([tip0[:, None], p, tip1[:, None]], dim=1)

    def set_shape(self, root_pose, bend: torch.Tensor):
        """Lay the rope from `root_pose` (first capsule) with joint angles `bend` [B, 2 * (segments - 1)], at rest."""
        self.articulation.set_root_pose(root_pose)
        self.articulation.set_qpos(bend)
        self.articulation.set_qvel(torch.zeros_like(bend))
        self.articulation.set_root_linear_velocity(torch.zeros(bend.shape[0], 3, device=bend.device))
        self.articulation.set_root_angular_velocity(torch.zeros(bend.shape[0], 3, device=bend.device))

    def lay_flat(self, middle: torch.Tensor, heading: torch.Tensor, turns: torch.Tensor, from_tip: bool = False):
        """Lay the rope flat on the table (z = radius), at rest, curved in the table's plane: `turns`
        [B, segments - 1] are the in-plane bend angles (rad, counter-clockwise) between consecutive
        capsules, `heading` [B] the yaw of the first capsule; the mean of the capsule centres lands on the
        xy of `middle` [B, 2 or 3] (`from_tip`: the first tip lands there instead, as for an anchored rope).
        Returns the laid capsule centres, [B, segments, 3] (on the GPU backend the links' poses show them only
        after the next physics update)."""
        b, n = turns.shape[0], self.config.segments
        centres = flat_centres(turns, heading, self.config.segment_length)
        first_step = torch.stack([torch.cos(heading), torch.sin(heading)], dim=-1) * (self.config.segment_length / 2)
        first = middle[:, :2] + (first_step if from_tip else -centres.mean(dim=1))
        root = torch.cat([first, torch.full((b, 1), self.config.radius, device=turns.device)], dim=1)
        bend = torch.zeros(b, 2 * (n - 1), device=turns.device)
        bend[:, 0::2] = turns
        self.set_shape(Pose.create_from_pq(root, yaw_quat(heading)), bend)
        return torch.cat([first[:, None] + centres, root[:, None, 2:].expand(b, n, 1)], dim=2)


def _merge_bodies(links: list[Link], name: str) -> Link:
    """One view of several links' bodies, for one pose query (`Link.merge` without its joint: it would merge the
    links' joints unless one link is the root, and a rope tied to another articulation has a fixed first joint
    without an active index)."""
    merged = Link.create([body for link in links for body in link._objs], scene=links[0].scene,
                         scene_idxs=torch.concat([link._scene_idxs for link in links]))
    merged.articulation = None
    merged.name = name
    merged.merged = True
    return merged


# `crumpled_turns`: the curl (rad of turn per joint, either sense), the meander's amplitude (rad), its number of
# periods along the rope and the per-joint noise (rad)
CRUMPLE_CURL = 0.15
CRUMPLE_AMP = (0.35, 0.6)
CRUMPLE_CYCLES = (1.0, 2.0)
CRUMPLE_NOISE = 0.1


def wavy_turns(batch: int, segments: int, max_amp: float) -> torch.Tensor:
    """Random in-plane turns for `Rope.lay_flat`, [batch, segments - 1]: a gentle S, the turn after capsule
    k being amp * sin(2 pi (k + 1) / segments + phase), amp uniform in [0, max_amp] rad, phase uniform
    (on torch's default device)."""
    k = torch.arange(1, segments)
    amp = torch.rand(batch, 1) * max_amp
    return amp * torch.sin(2 * np.pi * k / segments + torch.rand(batch, 1) * 2 * np.pi)


def flat_centres(turns: torch.Tensor, heading: torch.Tensor, segment_length: float) -> torch.Tensor:
    """Top-down capsule centres [B, segments, 2] of a rope laid flat (`Rope.lay_flat`) with in-plane `turns`
    [B, segments - 1] and first-capsule yaw `heading` [B], its first capsule centre at the origin."""
    b = turns.shape[0]
    yaw = heading[:, None] + torch.cat([torch.zeros(b, 1, device=turns.device), turns.cumsum(dim=1)], dim=1)
    step = torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=-1) * (segment_length / 2)
    return torch.cat([torch.zeros(b, 1, 2, device=turns.device), (step[:, :-1] + step[:, 1:]).cumsum(dim=1)], dim=1)


def flat_points(turns: torch.Tensor, heading: torch.Tensor, config: RopeConfig) -> torch.Tensor:
    """The polyline (`Rope.points`: first tip, capsule centres, last tip; z = 0) [B, segments + 2, 3] of a rope
    laid flat with `turns` and `heading` (`flat_centres`), its first capsule centre at the origin."""
    centres = flat_centres(turns, heading, config.segment_length)
    yaw = torch.stack([heading, heading + turns.sum(dim=1)], dim=1)
    half = config.segment_length / 2 * torch.stack([torch.cos(yaw), torch.sin(yaw)], dim=-1)
    points = torch.cat([centres[:, :1] - half[:, :1], centres, centres[:, -1:] + half[:, 1:]], dim=1)
    return torch.nn.functional.pad(points, (0, 1))


def min_self_distance(centres: torch.Tensor, skip: int = 2) -> torch.Tensor:
    """Smallest distance between the centres [B, N, 2 or 3] of two capsules at least `skip` apart along the
    chain, [B] (capsules that close lie side by side: the distance between their axes; 2 * radius or less
    means they overlap)."""
    n = centres.shape[1]
    d = torch.cdist(centres, centres)
    k = torch.arange(n, device=centres.device)
    near = (k[:, None] - k[None, :]).abs() < skip
    return d.masked_fill(near, float("inf")).flatten(1).amin(dim=1)


def crumpled_turns(batch: int, config: RopeConfig, max_straightness: float, clearance: float,
                   tries: int = 64) -> torch.Tensor:
    """In-plane turns [batch, segments - 1] (for `Rope.lay_flat`) of a rope crumpled flat on the table: a
    meander with a curl, the turn after capsule k being curl + amp * sin(2 pi cycles (k + 1) / segments +
    phase) + noise, curl uniform in +-`CRUMPLE_CURL`, amp uniform in `CRUMPLE_AMP`, cycles uniform in
    `CRUMPLE_CYCLES`, phase uniform, noise uniform in +-`CRUMPLE_NOISE` (rad); drawn `tries` times per rope
    and the first kept whose `straightness` (of its `flat_points`) is at most `max_straightness` and whose
    capsules at least two apart along the chain keep at least 2 radius + `clearance` between their axes (no
    capsule laid into another). On torch's default device; raises if a rope gets no draw that passes."""
    n = config.segments
    shape = (batch, tries, 1)
    k = torch.arange(1, n)
    curl = (torch.rand(shape) * 2 - 1) * CRUMPLE_CURL
    amp = CRUMPLE_AMP[0] + torch.rand(shape) * (CRUMPLE_AMP[1] - CRUMPLE_AMP[0])
    cycles = CRUMPLE_CYCLES[0] + torch.rand(shape) * (CRUMPLE_CYCLES[1] - CRUMPLE_CYCLES[0])
    phase = torch.rand(shape) * 2 * np.pi
    noise = (torch.rand(batch, tries, n - 1) * 2 - 1) * CRUMPLE_NOISE
    turns = curl + amp * torch.sin(2 * np.pi * cycles * k / n + phase) + noise
    turns = turns.clamp(-config.max_bend, config.max_bend)
    flat = turns.reshape(batch * tries, n - 1)
    points = flat_points(flat, torch.zeros(batch * tries), config)
    ok = ((straightness(points) <= max_straightness)
          & (min_self_distance(points[:, 1:-1]) >= 2 * config.radius + clearance))
    ok = ok.reshape(batch, tries)
    if not bool(ok.any(dim=1).all()):
        raise RuntimeError(f"no crumpled layout passed in {tries} draws")
    first = ok.float().argmax(dim=1)
    return turns[torch.arange(batch), first]


def segment_axis(q: torch.Tensor) -> torch.Tensor:
    """A capsule's long axis in the world, [B, 3], from its link's wxyz quaternions q [B, 4] (capsules lie
    along their link's local x: the first column of the rotation)."""
    w, x, y, z = q.unbind(-1)
    return torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)], dim=-1)


def segment_yaw(q: torch.Tensor) -> torch.Tensor:
    """The heading of a capsule's long axis in the table plane, [B] radians (what a top-down grasp of it aligns to)."""
    axis = segment_axis(q)
    return torch.atan2(axis[..., 1], axis[..., 0])


def build_rope(scene: ManiSkillScene, name: str, config: RopeConfig = RopeConfig(), fix_first_end: bool = False,
               initial_pose: sapien.Pose = sapien.Pose()) -> Rope:
    """Build a straight rope along the local x axis of `initial_pose`, its first capsule at that pose.

    fix_first_end: fix the first capsule in place (a cable hanging from a point); otherwise the rope is free.
    Joints are named `bend_z_<i>`, `bend_y_<i>`; capsule links `capsule_<i>`.
    """
    builder = scene.create_articulation_builder()
    builder.initial_pose = initial_pose
    add_rope_links(scene, builder, config)
    articulation = builder.build(name=name, fix_root_link=fix_first_end)
    configure_rope(articulation, config)
    return Rope(articulation, config)


def add_rope_links(scene: ManiSkillScene, builder, config: RopeConfig, parent=None, attach: sapien.Pose = None):
    """Add a rope's links (`capsule_<i>`, `middle_<i>`) and bend joints (`bend_z_<i>`, `bend_y_<i>`) to an
    articulation builder, straight along the first capsule's local x. `parent`: None (the first capsule is the
    articulation's root) or a link builder the first capsule is fixed to, its centre at `attach` (a pose in the
    parent's frame): a rope tied to a part of another articulation (a spool's drum). After `builder.build`, call
    `configure_rope` on the articulation."""
    seg = config.segment_length
    half = seg / 2 - config.radius  # the capsule's cylinder part; its tips reach the joint points
    capsule_mass = config.mass / config.segments
    material = physx.PhysxMaterial(config.friction, config.friction, 0.0)
    colors = {0: config.end_color, config.segments - 1: config.end_color}
    for i in range(config.segments):
        if i > 0:
            middle = builder.create_link_builder(parent)
            middle.set_name(f"middle_{i}")
            middle.set_joint_name(f"bend_z_{i}")
            middle.set_joint_properties(
                "revolute", [[-config.max_bend, config.max_bend]],
                sapien.Pose(p=[seg / 2, 0, 0]) * X_TO_Z, X_TO_Z,
            )
            m = MIDDLE_LINK_MASS_FRACTION * capsule_mass
            middle.set_mass_and_inertia(m, sapien.Pose(), np.full(3, m * seg**2 / 12))
            parent = middle
        capsule = builder.create_link_builder(parent)
        capsule.set_name(f"capsule_{i}")
        if i > 0:
            capsule.set_joint_name(f"bend_y_{i}")
            capsule.set_joint_properties(
                "revolute", [[-config.max_bend, config.max_bend]], X_TO_Y, sapien.Pose(p=[-seg / 2, 0, 0]) * X_TO_Y
            )
        elif parent is not None:
            capsule.set_joint_name("rope_tie")
            capsule.set_joint_properties("fixed", [], attach, sapien.Pose())
        capsule.add_capsule_collision(radius=config.radius, half_length=half, material=material)
        capsule.set_mass_and_inertia(
            capsule_mass, sapien.Pose(),
            np.full(3, capsule_mass * seg**2 / 12),
        )
        if scene.can_render():
            mat = sapien.render.RenderMaterial(base_color=list(colors.get(i, config.color)), roughness=0.8)
            capsule.add_capsule_visual(radius=config.radius, half_length=half, material=mat)
        parent = capsule


def configure_rope(articulation: Articulation, config: RopeConfig):
    """What a built articulation holding a rope (`add_rope_links`) needs: contacts between neighbouring capsules
    off, `config`'s solver iterations (the whole articulation's), depenetration cap on the rope's links, bend
    drives, armature and speed cap on its bend joints."""
    _ignore_neighbour_contacts(articulation, config.segments)
    for art in articulation._objs:
        art.set_solver_position_iterations(config.solver_position_iterations)
    for link in articulation.links:
        if not _is_rope_link(link.name):
            continue
        for body in link._objs:
            body.set_max_depenetration_velocity(config.max_depenetration_velocity)
    for joint in articulation.active_joints:
        if not _is_rope_joint(joint.name):
            continue
        joint.set_drive_properties(config.bend_stiffness, config.bend_damping)
        for j in joint._objs:
            j.set_armature([config.armature])
            j.set_max_velocity(config.max_joint_velocity)


def _is_rope_link(name: str) -> bool:
    return re.fullmatch(r"(.*_)?(capsule|middle)_\d+", name) is not None


def _is_rope_joint(name: str) -> bool:
    return re.fullmatch(r"(.*_)?bend_[zy]_\d+", name) is not None


def _ignore_neighbour_contacts(articulation: Articulation, segments: int):
    """Switch off contacts between consecutive capsules only.

    They touch at their joint (PhysX skips only parent-child pairs, and a middle link sits between
    them), and fighting that contact made the chain blow up. Capsule i carries bits i and i + 1
    (mod 32) of group 2, so only neighbours share one; capsules further apart still collide, so the
    rope can lie on itself and knot. All ropes share ROPE_GROUP_ID, so rope A's capsule i ignores
    rope B's capsules i - 1, i, i + 1: keep two ropes apart or accept that.
    """
    for i in range(segments):
        bits = (1 << (i % NEIGHBOUR_BITS)) | (1 << ((i + 1) % NEIGHBOUR_BITS))
        for link in articulation.links_map[f"capsule_{i}"]._objs:
            for shape in link.get_collision_shapes():
                groups = shape.get_collision_groups()
                groups[2] |= bits
                groups[3] = (groups[3] & 0xFFFF0000) | ROPE_GROUP_ID
                shape.set_collision_groups(groups)


# ---- metrics --------------------------------------------------------------------------------------
def arc_length(points: torch.Tensor) -> torch.Tensor:
    """Length of the polyline `points` [B, N, 3] -> [B]."""
    return torch.linalg.norm(points[:, 1:] - points[:, :-1], dim=-1).sum(dim=1)


def end_to_end_distance(points: torch.Tensor) -> torch.Tensor:
    """Distance between the first and last point, [B]."""
    return torch.linalg.norm(points[:, -1] - points[:, 0], dim=-1)


def straightness(points: torch.Tensor) -> torch.Tensor:
    """End-to-end distance / arc length, [B]: 1 for a straight rope, near 0 for a coiled one."""
    return end_to_end_distance(points) / arc_length(points)


def winding_number(points: torch.Tensor, axis_xy: torch.Tensor) -> torch.Tensor:
    """Signed turns of the polyline about the vertical axis through `axis_xy` [B, 2] (or [2]), [B].

    The angle swept by the rope around the axis in the top-down view, in turns (counter-clockwise
    positive): 1 means the rope wraps once around a peg or post standing there.
    """
    rel = points[..., :2] - axis_xy.reshape(-1, 1, 2)
    angle = torch.atan2(rel[..., 1], rel[..., 0])
    step = torch.diff(angle, dim=1)
    step = (step + np.pi) % (2 * np.pi) - np.pi  # each step is the short way round
    return step.sum(dim=1) / (2 * np.pi)


def wound_around(points: torch.Tensor, axis_xy: torch.Tensor, min_turns: float, top: float):
    """The WrapRope tasks' wrap: (turns [B]: `winding_number` about the vertical axis through `axis_xy`,
    wound [B]: |turns| >= `min_turns`, below [B]: every rope point lower than `top` (m above the table), so the
    turns lie round the object, not over it)."""
    turns = winding_number(points, axis_xy)
    return turns, turns.abs() >= min_turns, (points[..., 2] < top).all(dim=1)

def through_ring(points: torch.Tensor, centre: torch.Tensor, normal: torch.Tensor, radius: float):
    """Where the polyline `points` [B, N, 3] passes through a ring: the ring's disc (centre `centre` [B, 3], unit
    axis `normal` [B, 3], inner radius `radius`). A crossing is a polyline segment whose ends lie on the two sides
    of the disc's plane and which meets the plane less than `radius` from the centre. Returns (count [B]: the
    number of crossings (long): one for a rope threaded once, two for one threaded through and back; shorter [B]:
    over the crossings, the largest arc length (m) of the shorter of the rope's two parts on either side of it,
    0 without a crossing: a rope threaded with at least L on each side has shorter >= L)."""
    d = ((points - centre[:, None]) * normal[:, None]).sum(dim=-1)  # signed distance from the plane, [B, N]
    d0, d1 = d[:, :-1], d[:, 1:]
    sides = (d0 * d1 < 0) | ((d0 == 0) & (d1 != 0))
    t = (d0 / (d0 - d1).where(d0 != d1, torch.ones_like(d0))).clamp(0, 1)  # where each segment meets the plane
    seg = points[:, 1:] - points[:, :-1]
    hit = points[:, :-1] + t[..., None] * seg
    off = hit - centre[:, None]
    off = off - (off * normal[:, None]).sum(dim=-1, keepdim=True) * normal[:, None]
    crossing = sides & (torch.linalg.norm(off, dim=-1) < radius)
    lengths = torch.linalg.norm(seg, dim=-1)
    before = torch.cumsum(lengths, dim=1) - lengths + t * lengths  # arc length from the first point to the crossing
    shorter = torch.minimum(before, lengths.sum(dim=1, keepdim=True) - before)
    return crossing.sum(dim=1), torch.where(crossing, shorter, torch.zeros_like(shorter)).amax(dim=1)


def crossings(points: np.ndarray) -> list[tuple[float, float, bool]]:
    """Self-crossings of the top-down projection of one polyline `points` [N, 3].

    Each crossing is (s_a, s_b, a_over): the positions along the rope (in segment units, s_a < s_b)
    of the two crossing strands and whether the earlier strand lies above the later one there.
    Segments sharing a point are not compared.
    """
    p = np.asarray(points, dtype=float)
    a0, a1 = p[:-1], p[1:]
    found = []
    for i in range(len(a0)):
        for j in range(i + 2, len(a0)):
            hit = _segment_intersection(a0[i, :2], a1[i, :2], a0[j, :2], a1[j, :2])
            if hit is None:
                continue
            t, u = hit
            z_i = a0[i, 2] + t * (a1[i, 2] - a0[i, 2])
            z_j = a0[j, 2] + u * (a1[j, 2] - a0[j, 2])
            found.append((i + t, j + u, bool(z_i > z_j)))
    return found


def _segment_intersection(p, p2, q, q2):
    """(t, u) in [0, 1]^2 where 2D segments p-p2 and q-q2 cross, or None."""
    r, s = p2 - p, q2 - q
    denom = r[0] * s[1] - r[1] * s[0]
    if abs(denom) < 1e-12:
        return None
    d = q - p
    t = (d[0] * s[1] - d[1] * s[0]) / denom
    u = (d[0] * r[1] - d[1] * r[0]) / denom
    return (t, u) if 0 <= t <= 1 and 0 <= u <= 1 else None


def is_knotted(points: np.ndarray) -> bool:
    """Knot test on one polyline `points` [N, 3] from its top-down crossing diagram.

    True when the rope crosses itself at least 3 times and, walking along it, the crossings it passes
    alternate over, under, over, ... (the diagram of an overhand knot). Loose coils and a rope merely
    laid across itself do not alternate, so they are not knots. A diagram test, not a proof: an
    alternating diagram with >= 3 crossings is knotted as long as it has no removable twist.
    """
    found = crossings(points)
    if len(found) < 3:
        return False
    passes = sorted([(a, over) for a, _, over in found] + [(b, not over) for _, b, over in found])
    return all(passes[k][1] != passes[k + 1][1] for k in range(len(passes) - 1))
