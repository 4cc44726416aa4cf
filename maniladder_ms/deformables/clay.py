"""Clay / plasticine: a lattice of small spheres held together by spring drives that yield.

Particles sit on a cubic lattice (`clay_ball`, `clay_block`); each face-neighbour pair is linked by
a PhysX D6 drive pulling the second particle to a rest offset from the first. Particles cannot
rotate (locked angular motion), so the offsets stay in the world frame and one link resists both
stretch and shear. Plasticity: once per control step the task calls `Clay.relax()`, which moves the
rest offset of every link strained past `yield_distance` back to exactly that strain (perfect
plasticity, a return mapping, batched in torch over envs and links). The clay springs back from
small pokes, and keeps the shape it is pressed into beyond that. Contacts between the spheres keep
its volume. The rest offsets are state: `Clay.state()` / `Clay.set_state()`. Envs holding clay subclass
`ClayHolder`, which does both chores: `relax()` after every control step, and the rest offsets in
the env state (`get_state_dict` / `set_state_dict`, and the flat `get_state` / `set_state`).

The drive targets are set through SAPIEN per sub-scene (ManiSkill 3.0.1 wraps no batched setter);
on the GPU backend they are set per env the same way, untested here (no GPU on the build machine).

Metrics on particle positions [B, N, 3] (`Clay.positions()`), lengths in metres:
- `height`: top of the highest sphere above the lowest one's bottom;
- `width_along`: extent along a horizontal axis (squeezing narrows it);
- `surface_height_at`: top of the clay near a table point; `dent_depth`: a reference top minus it;
- footprint area / IoU with a target footprint or voxel grid: `maniladder_ms.deformables.metrics`
  with tile = the clay's spacing;
- `top_layer`, `imprint_iou`: which top-layer cells a tool pressed in at least a depth, against the cells
  under its footprint (a stamp's imprint; footprint shapes such as `metrics.inside_star`);
- `cells_occupied`: which columns of a square grid on the table hold clay low enough (the one rasteriser of
  the grid metrics); `occupancy_iou`: their IoU with a target footprint on that grid (`l_footprint`: an L);
- `cup_depth`: how deep a cavity the clay holds with walls on all sides of it (a pinched cup);
- `mould_cells_filled`, `mould_fill`: which cells of a square mould's floor grid hold clay below its rim, and
  their share (`Mould`: the mould itself, an open square frame of walls fixed on the table).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.structs.actor import Actor

from maniladder_ms.geometry import yaw_of
from maniladder_ms.objects.tabletop import boxes_builder, open_box_parts

from . import metrics
from .spheres import SphereSet, build_spheres

CONTACT_OFFSET = 0.002  # m: the lattice packs spheres within a millimetre of each other


@dataclass(frozen=True)
class ClayConfig:
    """spacing: lattice spacing (m); radius: sphere radius (m), just under spacing / 2 so neighbours
    nearly touch; density of the clay (kg/m^3, one lattice cell per particle); stiffness (N/m) and
    damping (N s/m) of each link; yield_distance (m): strain of a link beyond which it deforms
    permanently (stiffness * yield_distance is a link's yield force); friction; color."""

    spacing: float = 0.012
    radius: float = 0.0058
    density: float = 1500.0
    stiffness: float = 300.0
    damping: float = 2.0
    yield_distance: float = 0.0015
    friction: float = 0.8
    color: tuple = (0.85, 0.45, 0.55, 1)


def _lattice(inside, extent: np.ndarray, spacing: float) -> np.ndarray:
    """Lattice points within `extent` (half sizes) for which `inside(points)` holds, bottom at z = 0."""
    axes = [np.arange(-np.floor(e / spacing), np.floor(e / spacing) + 1) * spacing for e in extent]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    points = points[inside(points)]
    points[:, 2] -= points[:, 2].min()
    return points


def clay_ball(radius: float = 0.03, spacing: float = ClayConfig.spacing) -> np.ndarray:
    """Rest positions [N, 3] of a ball of `radius`, lowest particle centre at z = 0."""
    return _lattice(lambda p: np.linalg.norm(p, axis=1) <= radius, np.full(3, radius), spacing)


def clay_block(half_size=(0.03, 0.03, 0.015), spacing: float = ClayConfig.spacing) -> np.ndarray:
    """Rest positions [N, 3] of a box of `half_size`, lowest particle centre at z = 0."""
    half = np.asarray(half_size, float)
    return _lattice(lambda p: np.all(np.abs(p) <= half + 1e-9, axis=1), half, spacing)


def _face_links(positions: np.ndarray, spacing: float) -> list[tuple[int, int]]:
    """Pairs of lattice points one spacing apart along x, y or z."""
    keys = {tuple(k): i for i, k in enumerate(np.round(positions / spacing).astype(int).tolist())}
    links = []
    for key, i in keys.items():
        for axis in range(3):
            step = list(key)
            step[axis] += 1
            j = keys.get(tuple(step))
            if j is not None:
                links.append((i, j))
    return links


class Clay(SphereSet):
    """A built clay body: its particles (a `SphereSet`), the link `drives`, the linked index pairs and
    the rest offsets `rest` [B, L, 3] the drives pull towards."""

    def __init__(self, spheres: list[Actor], name: str, drives: list, links: list[tuple[int, int]],
                 layout: np.ndarray, config: ClayConfig, num_envs: int, device):
        super().__init__(spheres, name)
        self.name = name
        self.drives = drives
        self.layout = layout
        self.config = config
        self.first = torch.tensor([i for i, _ in links], device=device)
        self.second = torch.tensor([j for _, j in links], device=device)
        offsets = torch.as_tensor(layout[[j for _, j in links]] - layout[[i for i, _ in links]], dtype=torch.float32, device=device)
        self.initial_rest = offsets
        self.rest = offsets[None].repeat(num_envs, 1, 1)
        self.start = torch.as_tensor(layout, dtype=torch.float32, device=device)[None].repeat(num_envs, 1, 1)

    def reset(self, env_idx: torch.Tensor, origin: torch.Tensor, yaw: torch.Tensor | None = None,
              scale: torch.Tensor | None = None):
        """Put the envs' clay back to its rest shape with its lowest particles' centres at `origin` [b, 3],
        the shape turned by `yaw` [b] about z and scaled by `scale` [b] about its bottom centre (>= 1,
        or neighbouring spheres overlap; the spheres keep their size, the links their stiffness).
        The placed positions are kept as `start` [B, N, 3], the reference of a task's metrics."""
        b, device = len(env_idx), origin.device
        transform = torch.eye(3, device=device).repeat(b, 1, 1)
        if yaw is not None:
            c, s = torch.cos(yaw), torch.sin(yaw)
            transform[:, 0, 0], transform[:, 0, 1], transform[:, 1, 0], transform[:, 1, 1] = c, -s, s, c
        if scale is not None:
            transform = transform * scale[:, None, None]
        layout = torch.as_tensor(self.layout, dtype=torch.float32, device=device)
        local = layout[None] @ transform.transpose(1, 2)  # [b, N, 3]
        placed = origin[:, None] + local
        self.place(placed.transpose(0, 1).reshape(-1, 3))
        self.start[env_idx] = placed
        self.rest[env_idx] = self.initial_rest[None] @ transform.transpose(1, 2)
        self._push_targets(env_idx, torch.ones(b, len(self.drives), dtype=torch.bool, device=device))

    def relax(self):
        """Plastic step: clamp every link's strain (offset - rest) to `yield_distance` by moving its rest offset."""
        p = self.positions()
        strain = p[:, self.second] - p[:, self.first] - self.rest
        size = torch.linalg.norm(strain, dim=-1, keepdim=True)
        yielded = size[..., 0] > self.config.yield_distance
        if not bool(yielded.any()):
            return
        excess = strain * (1 - self.config.yield_distance / size.clamp_min(1e-9))
        self.rest = torch.where(yielded[..., None], self.rest + excess, self.rest)
        self._push_targets(torch.arange(len(p), device=p.device), yielded)

    def state(self) -> torch.Tensor:
        """The plastic state: rest offsets, [B, L * 3]."""
        return self.rest.flatten(1).clone()

    def set_state(self, state: torch.Tensor, env_idx: torch.Tensor):
        """Restore rest offsets saved by `state()` for the envs `env_idx`."""
        self.rest[env_idx] = state.reshape(len(env_idx), -1, 3).to(self.rest)
        self._push_targets(env_idx, torch.ones(len(env_idx), len(self.drives), dtype=torch.bool))

    def set_start(self, start: torch.Tensor, env_idx: torch.Tensor):
        """Restore the start positions (flattened [b, N * 3]) of the envs `env_idx`."""
        self.start[env_idx] = start.reshape(len(env_idx), -1, 3).to(self.start)

    def _push_targets(self, env_idx: torch.Tensor, which: torch.Tensor):
        """Send the rest offsets of the links marked in `which` [b, L] to their PhysX drives."""
        rows, links = torch.nonzero(which.cpu(), as_tuple=True)
        envs = env_idx.cpu()[rows].tolist()
        targets = self.rest.cpu()[envs, links.tolist()].tolist() if len(envs) else []
        for env, link, target in zip(envs, links.tolist(), targets):
            self.drives[link]._objs[env].set_drive_target(sapien.Pose(p=target))


class ClayHolder:
    """Plumbing for envs that hold `Clay` bodies (list them in `clay_bodies`; default: `self.clay`).
    Put it before the env base class, `class MyEnv(ClayHolder, ManiLadderEnv)`:

    - plasticity: every clay body `relax()`es after each control step;
    - state: each body's rest offsets (`<name>_rest`) and start positions (`<name>_start`, what its
      task measures against) are extra state fields of the base env (`_extra_state_fields`: in
      `get_state_dict`, set back by `set_state_dict` and the flat `set_state`), so recorded demos and
      replays from env states keep the clay's plastic shape and reference.
    """

    # PhysX keeps contact caches outside the env state. With the clay's hundreds of persistent contacts
    # a run restored into a scene that simulated on diverges within one step from another restore into
    # the same scene (measured: particle velocities apart by metres per second after the robot had
    # kneaded the clay), while restores into freshly built scenes agree exactly: state checks use those
    RESTORES_NEED_FRESH_SCENE: ClassVar[bool] = True

    clay_config: ClassVar[ClayConfig] = ClayConfig()

    def clay_bodies(self) -> list[Clay]:
        return [self.clay]

    def load_clay(self, layout: np.ndarray):
        """Build the env's clay, `self.clay`, with particles at `layout` (`clay_ball`, `clay_block`)."""
        self.clay = build_clay(self.scene, "clay", layout, self.clay_config)

    def _extra_state_fields(self):
        """The base env's fields (episode memory), then each clay body's rest offsets and start positions."""
        yield from super()._extra_state_fields()
        for body in self.clay_bodies():
            yield f"{body.name}_rest", body.state(), body.set_state
            yield f"{body.name}_start", body.start.flatten(1).clone(), body.set_start

    def _after_control_step(self):
        for body in self.clay_bodies():
            body.relax()
        super()._after_control_step()  # the episode memory sees the relaxed clay


def build_clay(scene: ManiSkillScene, name: str, layout: np.ndarray, config: ClayConfig = ClayConfig()) -> Clay:
    """Build clay with particles at `layout` [N, 3] (`clay_ball`, `clay_block`); place it with `Clay.reset`."""
    material = physx.PhysxMaterial(config.friction, config.friction, 0.0)
    mass = config.density * config.spacing**3
    density = mass / (4 / 3 * np.pi * config.radius**3)
    render_mat = sapien.render.RenderMaterial(base_color=list(config.color), roughness=0.9) if scene.can_render() else None

    def add_visual(builder, i: int):  # drawn a little larger than they collide, so the body reads as one lump
        builder.add_sphere_visual(radius=config.spacing * 0.62, material=render_mat)

    particles = build_spheres(scene, name, layout, config.radius, material, density, CONTACT_OFFSET, add_visual)
    for particle in particles:
        for body in particle._bodies:  # translation only: link offsets stay in the world frame
            body.set_locked_motion_axes([False, False, False, True, True, True])
    links = _face_links(layout, config.spacing)
    drives = []
    for i, j in links:
        drive = scene.create_drive(particles[i], sapien.Pose(), particles[j], sapien.Pose())
        drive.set_drive_property_x(config.stiffness, config.damping)
        drive.set_drive_property_y(config.stiffness, config.damping)
        drive.set_drive_property_z(config.stiffness, config.damping)
        drives.append(drive)
    return Clay(particles, name, drives, links, layout, config, scene.num_envs, scene.device)


# ---- metrics --------------------------------------------------------------------------------------
def height(points: torch.Tensor, radius: float) -> torch.Tensor:
    """Height of the clay (top of the highest sphere above the bottom of the lowest), [B]."""
    z = points[..., 2]
    return z.amax(dim=1) - z.amin(dim=1) + 2 * radius


def width_along(points: torch.Tensor, axis: torch.Tensor, radius: float) -> torch.Tensor:
    """Extent of the clay along the horizontal direction `axis` [2] or [B, 2] (unit), spheres included, [B]."""
    s = (points[..., :2] * axis.reshape(-1, 1, 2)).sum(dim=-1)
    return s.amax(dim=1) - s.amin(dim=1) + 2 * radius


def surface_height_at(points: torch.Tensor, xy: torch.Tensor, within: float, radius: float) -> torch.Tensor:
    """Top of the clay (highest sphere top) within `within` of the table point xy [2] or [B, 2], [B];
    0 where no particle is that close."""
    near = torch.linalg.norm(points[..., :2] - xy.reshape(-1, 1, 2), dim=-1) <= within
    top = torch.where(near, points[..., 2] + radius, torch.zeros_like(points[..., 2]))
    return top.amax(dim=1)


def dent_depth(points: torch.Tensor, xy: torch.Tensor, reference_top: torch.Tensor, within: float, radius: float) -> torch.Tensor:
    """How far (m) the clay surface near xy lies below `reference_top` [B] (e.g. its height before), [B]."""
    return reference_top - surface_height_at(points, xy, within, radius)


def top_layer(start: torch.Tensor, spacing: float) -> torch.Tensor:
    """The particles of the clay's top layer at the start (within half a lattice spacing of the highest), [B, N]."""
    z = start[..., 2]
    return z >= z.amax(dim=1, keepdim=True) - spacing / 2


def imprint_iou(start: torch.Tensor, points: torch.Tensor, under: torch.Tensor, depth: float, spacing: float) -> torch.Tensor:
    """How well an imprint matches a tool's footprint, [B]: the intersection over union of two sets of the
    top layer's cells (particles, each standing for its lattice cell): those that sank at least `depth` (m)
    below their start height (`start` [B, N, 3] -> `points`), and those `under` [B, N] the tool's footprint
    (e.g. a stamp's outline, placed where it pressed, tested at the particles' start xy). 1: exactly the
    footprint's cells sank; a dent beside the footprint, or a press over all of the clay, scores low."""
    top = top_layer(start, spacing)
    sunk = top & (start[..., 2] - points[..., 2] >= depth)
    target = top & under
    inter = (sunk & target).sum(dim=1)
    union = (sunk | target).sum(dim=1).clamp_min(1)
    return inter / union


def cells_occupied(points: torch.Tensor, centre: torch.Tensor, yaw: torch.Tensor, half: float, max_height: float,
                   cells: int) -> torch.Tensor:
    """Which columns of a square grid on the table hold clay, [B, cells, cells] bool. The grid (side 2 `half`,
    centred at `centre` [B, 2+] on the table, turned by `yaw` [B]) is divided into `cells` x `cells` equal square
    columns, indexed [along the grid's x, along its y]; a column is occupied when a particle centre (`points`
    [B, N, 3]) lies in it no higher than `max_height` above the table: clay outside the grid, or lifted or stacked
    above that height, occupies nothing."""
    local = torch.stack(metrics.channel_coords(points, centre, yaw), dim=-1)  # the grid's own axes
    index = torch.floor((local + half) / (2 * half / cells)).long()
    inside = ((index >= 0) & (index < cells)).all(dim=-1) & (points[..., 2] <= max_height)
    flat = torch.where(inside, index[..., 0] * cells + index[..., 1], torch.full_like(index[..., 0], cells * cells))
    filled = torch.zeros(points.shape[0], cells * cells + 1, dtype=torch.bool, device=points.device)
    filled.scatter_(1, flat, True)
    return filled[:, :-1].reshape(-1, cells, cells)


def occupancy_iou(points: torch.Tensor, centre: torch.Tensor, yaw: torch.Tensor, half: float, max_height: float,
                  target: torch.Tensor) -> torch.Tensor:
    """Intersection over union of the clay's occupied columns (`cells_occupied` on the grid of `target`'s size)
    and a target footprint `target` [cells, cells] or [B, cells, cells] bool on that grid, [B]."""
    cells = target.shape[-1]
    return metrics.iou(cells_occupied(points, centre, yaw, half, max_height, cells), target)


def l_footprint(cells: int, margin: int) -> torch.Tensor:
    """An L on a `cells` x `cells` grid (`cells_occupied`'s indexing), [cells, cells] bool: the square `margin` cells
    in from each edge of the grid (its side even) without its quarter on the grid's +x, +y side."""
    side = cells - 2 * margin
    assert side > 0 and side % 2 == 0, "the L's square needs an even side"
    index = torch.arange(cells)
    square = (index >= margin) & (index < cells - margin)
    upper = index >= cells // 2
    return square[:, None] & square[None, :] & ~(upper[:, None] & upper[None, :])


def mould_cells_filled(points: torch.Tensor, centre: torch.Tensor, yaw: torch.Tensor, inner_half: float,
                       depth: float, cells: int) -> torch.Tensor:
    """Which cells of a square mould's floor hold clay, [B, cells, cells] bool (`cells_occupied` on the mould's
    inside: side 2 `inner_half`, centred at `centre` [B, 2+] on the table, turned by `yaw` [B]); a column is
    filled when a particle centre lies in it no higher than `depth` above the table (the rim): clay heaped on the
    rim or outside the walls fills nothing, nor does a particle stacked on others above the rim."""
    return cells_occupied(points, centre, yaw, inner_half, depth, cells)


def mould_fill(points: torch.Tensor, centre: torch.Tensor, yaw: torch.Tensor, inner_half: float, depth: float,
               cells: int) -> torch.Tensor:
    """Share of a square mould's floor cells that hold clay (`mould_cells_filled`), [B]."""
    return mould_cells_filled(points, centre, yaw, inner_half, depth, cells).flatten(1).float().mean(dim=1)


class Mould:
    """A square mould fixed on the table (a kinematic actor, `actor`): four walls `wall` thick and `depth`
    high round a square inside of side 2 `inner_half`, open on top, with no floor (clay pressed into it lies
    on the table). Its origin is the table point at the middle of its inside; its floor is read as
    `cells` x `cells` square columns (`fill`)."""

    def __init__(self, scene: ManiSkillScene, name: str, inner_half: float, depth: float, wall: float, cells: int,
                 color):
        walls = open_box_parts((inner_half, inner_half), depth, wall, 0.0)[1:]  # no base plate
        self.actor = boxes_builder(scene, walls, color).build_kinematic(name=name)
        self.inner_half, self.depth, self.wall, self.cells = inner_half, depth, wall, cells

    @property
    def pose(self):
        return self.actor.pose

    def set_pose(self, pose):
        self.actor.set_pose(pose)

    def yaw(self) -> torch.Tensor:
        """The mould's yaw about z, [B]."""
        return yaw_of(self.actor.pose.q)

    def cells_filled(self, points: torch.Tensor) -> torch.Tensor:
        """[B, cells, cells]: the floor's cells holding clay (`mould_cells_filled`)."""
        return mould_cells_filled(points, self.actor.pose.p, self.yaw(), self.inner_half, self.depth, self.cells)

    def fill(self, points: torch.Tensor) -> torch.Tensor:
        """Share of the floor's cells holding clay, [B] (`mould_fill`)."""
        return mould_fill(points, self.actor.pose.p, self.yaw(), self.inner_half, self.depth, self.cells)


# `cup_depth` bounds every centre's depth from above by its walls towards +x, +y, -x and -y (four of its directions
# when their number is a multiple of 4), each found in the sector widened by `CUP_BOUND_MARGIN` with no angles (a
# test on the particles' offsets, which holds every particle the exact sector holds and a few more), and tries every
# direction (the exact depth) only at each env's `CUP_PROBE_CENTRES` centres of the highest bounds and then wherever
# a bound beats the deepest of those. The 179-particle ball of 300 random-action steps: 0.84 ms a call (one core),
# every centre in every direction 13.3 ms; 8 probes 1.0 ms; half planes (dx > 0, ...) for the widened sectors 2.5 ms
CUP_BOUND_MARGIN = 1e-3  # rad: far over float32's error in the exact test's angles (~1e-6 rad)
CUP_PROBE_CENTRES = 2


def cup_depth(points: torch.Tensor, radius: float, floor_within: float, wall_within: float, arc: float,
              directions: int = 24) -> torch.Tensor:
    """How deep a cup the clay makes, [B]: the deepest cavity walled on all sides, in m (<= 0: none).

    Every particle's table point is tried as a cavity centre. There the floor is the clay's top within
    `floor_within` of the centre (`surface_height_at`); the walls: in each of `directions` directions evenly round
    the centre, the sector `arc` (rad) wide about it, from `floor_within` to `wall_within` out, holds a wall, the top
    of the clay in it (0 where it holds no particle). The cavity's depth is its lowest wall minus its floor: a gap
    in the walls as wide as a sector (plus a step between directions) anywhere round the centre makes it shallow (a
    dent open on a side, a "C"), as a flattened disk (walls as high as its floor) or the untouched ball (a floor at
    its top) do. A ring with nothing in its middle has no particle there to try: it is no cup (no floor).

    Computed exactly with less work than every direction round every centre: a cheap upper bound on each centre's
    depth (its walls in four directions; `CUP_BOUND_MARGIN`, `CUP_PROBE_CENTRES`) rules out the centres that cannot
    be the deepest; the others' depths are the same floats as with every centre tried (the same element-wise
    operations on the same values; maxima, minima exact)."""
    xy, top = points[..., :2], points[..., 2] + radius
    offset = xy[:, None, :, :] - xy[:, :, None, :]  # [B, centre, particle, 2]
    dist = torch.linalg.norm(offset, dim=-1)
    floor = torch.where(dist <= floor_within, top[:, None, :], 0.0).amax(dim=-1)  # [B, centre]
    ring_top = torch.where((dist > floor_within) & (dist <= wall_within), top[:, None, :], 0.0)  # [B, centre, particle]
    heading = torch.arange(directions, device=points.device) * (2 * np.pi / directions)

    def depth_at(env: torch.Tensor, centre: torch.Tensor) -> torch.Tensor:
        """The exact cavity depths at the centres (`env`, `centre`) [K], [K]."""
        rel = offset[env, centre]  # [K, particle, 2]
        angle = torch.atan2(rel[..., 1], rel[..., 0])
        off_heading = torch.remainder(angle[..., None] - heading + np.pi, 2 * np.pi) - np.pi  # [K, particle, dir]
        walls = torch.where(off_heading.abs() <= arc / 2, ring_top[env, centre][..., None], 0.0).amax(dim=1)  # [K, dir]
        return walls.amin(dim=-1) - floor[env, centre]

    bound = ring_top.amax(dim=-1) - floor  # [B, centre]: the ring's highest top (sectors of half a turn or more)
    reach = arc / 2 + CUP_BOUND_MARGIN
    if directions % 4 == 0 and reach < np.pi / 2:
        dx, dy = xy[:, None, :, 0] - xy[:, :, None, 0], xy[:, None, :, 1] - xy[:, :, None, 1]  # offset's, contiguous
        wide_x, wide_y = np.tan(reach) * dx, np.tan(reach) * dy
        across_x, across_y = dy.abs(), dx.abs()
        sectors = (across_x <= wide_x, across_y <= wide_y, across_x <= -wide_x, across_y <= -wide_y)  # +x, +y, -x, -y
        walls = torch.stack([(ring_top * sector).amax(dim=-1) for sector in sectors])  # [4, B, centre]
        bound = walls.amin(dim=0) - floor
    b, n = floor.shape
    probe = bound.topk(min(CUP_PROBE_CENTRES, n), dim=1).indices  # [B, k]
    probe_env = torch.arange(b, device=points.device)[:, None].expand_as(probe).flatten()
    best = depth_at(probe_env, probe.flatten()).reshape(probe.shape).amax(dim=1)
    env, centre = torch.nonzero(bound > best[:, None], as_tuple=True)
    if len(env):
        best = best.scatter_reduce(0, env, depth_at(env, centre), reduce="amax")
    return best
