"""Cloth: a sheet of small rigid particles linked by spring drives (towel, shirt, bag, tent panel).

Each particle is a sphere (collision; pinchable by a parallel gripper like a pen) carrying a thin
square tile as its visual, so the sheet renders as a surface. Neighbouring particles are linked by
a PhysX D6 drive whose two frames sit at the midpoint between them: the linear drive (stiff: stretch)
pulls the two midpoints together, the angular slerp drive (soft: bending) pulls the two particles
towards the same orientation. Linked at edge midpoints, each tile turns with the sheet around it,
so the tiles follow folds and drapes instead of spinning on their own. Jointed particles do not
collide with each other (PhysX's default for jointed pairs); all others do, so folds stack.

Budget: keep a sheet at or below about 12 x 12 particles; make larger cloth from larger particles.

Shapes (`ClothLayout`, all lying flat in their rest shape): `towel` (rows x cols), `shirt` (body
with two sleeves), `bag` (a tote bag lying flat: front and back panels sewn along both sides and
the bottom, a handle loop on each panel) and `tent_panel` (a sheet with corner grommets marked).

Metrics on particle positions [B, N, 3] (`Cloth.positions()`); the footprint ones live in
`maniladder_ms.deformables.metrics` with tile = the cloth's spacing:
- `metrics.footprint_area`: area (m^2) the sheet covers seen from above (flat: N * spacing^2);
- `metrics.region_coverage`: fraction of a table rectangle that the sheet covers;
- `coverage`: the share of the flat sheet's area it covers seen from above, in its own grid axes;
- `fold_distance`: mean distance between particles paired by a fold (0 when perfectly folded; `top_down`:
  seen from above, leaving out the two layers' thickness); the pairs of a fold in half: `fold_pairs`, of a
  square sheet's diagonal fold: `diagonal_fold_pairs`;
- `flatness`: standard deviation of particle heights (0 for a flat sheet);
- `fraction_below`: fraction of particles lower than a height (hanging below a bar);
- `fraction_beyond`: fraction of particles on the far side of a vertical plane (one side of a bar);
- `hanging_fractions`: per env, the fractions of particles hanging on each side of a horizontal bar.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.geometry.rotation_conversions import quaternion_multiply
from mani_skill.utils.structs.actor import Actor
from mani_skill.utils.structs.pose import Pose

from .metrics import footprint_area
from .spheres import SphereSet, build_spheres

CONTACT_OFFSET = 0.003  # m: small, so a sheet lying on itself tracks few contact pairs


@dataclass(frozen=True)
class ClothConfig:
    """spacing: distance between neighbouring particles (m); radius: particle collision radius (m),
    8 mm pinches like a pen. For folds (a layer lying on the sheet) it must exceed spacing / (2 sqrt 2),
    8.8 mm at 2.5 cm, or a particle of the upper layer drops through the hollow between the four
    particles below it to the table: at 8 mm a folded-over towel corner sinks through the sheet, at
    10 mm it rests on it (test_folded_towel_corner_...). The default stays 8 mm for now: at 10 mm a
    fully opened Panda gripper coming down on the draped showcase towel's corner landed on its
    neighbours in 3/8 picks (open the fingers less, as test_ee_delta_gripper_... does).
    particle_mass (kg); stretch_stiffness (N/m) and stretch_damping (N s/m) of the linear drives;
    bend_stiffness (N m/rad) and bend_damping (N m s/rad) of the angular drives;
    friction: static = dynamic; tile_thickness: half thickness (m) of the visual tiles; color of the
    tiles, border_color of the tiles on the outline.

    solver_position_iterations of every particle (PhysX takes the largest count in an island, so a
    gripper pinching the sheet is solved with it too): what lets a Panda hold a particle by friction.
    Measured with a Panda pinching a towel corner particle (closing across the corner's diagonal,
    +-0.3 rad, +-3 mm), lifting it 15 cm and holding 60 steps: at the scene's 15 the fingers sank
    8 mm into the 16 mm particle (gap 8.2 mm) and 3/16 grasps lost it; at 40 they stop on it
    (gap 13.9 mm) and 16/16 hold (at 25: gap 11.9 mm, 7/8). Cost: while the gripper holds the towel
    (one island) a control step takes 2.4x as long (80 vs 191 steps/s); a resting towel is unaffected.
    max_depenetration_velocity (m/s; 0: PhysX's default, unlimited) stays uncapped: capping it at
    1 m/s, as the rope does, let the fingers close through the particles (2/8 held).
    max_linear_velocity (m/s; 0: unlimited) caps a particle's speed.

    cord_bend_stiffness, cord_bend_damping (0: bend_stiffness, bend_damping): the angular drives of the links
    with a cord particle (`ClothLayout.cords`: a bag's handles, a towel's loop), so a loop can keep its shape
    (a stiff hanging ring) while the sheet stays soft."""

    spacing: float = 0.025
    radius: float = 0.008
    particle_mass: float = 0.002
    stretch_stiffness: float = 2000.0
    stretch_damping: float = 5.0
    bend_stiffness: float = 0.002
    bend_damping: float = 0.0005
    friction: float = 1.0
    tile_thickness: float = 0.0015
    solver_position_iterations: int = 40
    max_depenetration_velocity: float = 0.0
    max_linear_velocity: float = 0.0
    cord_bend_stiffness: float = 0.0
    cord_bend_damping: float = 0.0
    color: tuple = (0.2, 0.55, 0.75, 1)
    border_color: tuple = (0.95, 0.95, 0.95, 1)


@dataclass
class ClothLayout:
    """Rest shape of a sheet: particle positions [N, 3] (m, local frame), linked pairs, the particles
    on the outline, named particle indices (corners, handle particles, grommets...) and `cords`, the
    particles of a strap (bag handles) drawn as beads of a cord instead of tiles."""

    positions: np.ndarray
    links: list[tuple[int, int]]
    border: set[int]
    named: dict[str, list[int]] = field(default_factory=dict)
    cords: set[int] = field(default_factory=set)

    def neighbours(self, i: int) -> list[int]:
        """The particles linked to particle `i` (a towel corner's: the next one along each of its edges)."""
        return sorted(b if a == i else a for a, b in self.links if i in (a, b))


def _grid(mask: np.ndarray, spacing: float, z: float = 0.0, offset: int = 0):
    """Particles on the True cells of `mask` [rows, cols] (rows along x, cols along y), centred;
    returns positions, links between 4-neighbours, border particles and the cell -> index map."""
    rows, cols = mask.shape
    index = -np.ones(mask.shape, dtype=int)
    index[mask] = np.arange(mask.sum()) + offset
    r, c = np.nonzero(mask)
    positions = np.stack([(r - (rows - 1) / 2) * spacing, (c - (cols - 1) / 2) * spacing, np.full(len(r), z)], axis=1)
    links = []
    for a, b in ((index[:-1, :], index[1:, :]), (index[:, :-1], index[:, 1:])):
        both = (a >= 0) & (b >= 0)
        links += list(zip(a[both].tolist(), b[both].tolist()))
    padded = np.pad(mask, 1)
    inner = padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:]
    border = set(index[mask & ~inner].tolist())
    return positions, links, border, index


def towel(rows: int = 10, cols: int = 10, spacing: float = ClothConfig.spacing) -> ClothLayout:
    """A rectangular towel; named corners `corners` in the order (-x,-y), (-x,+y), (+x,-y), (+x,+y)."""
    positions, links, border, index = _grid(np.ones((rows, cols), bool), spacing)
    corners = [index[0, 0], index[0, -1], index[-1, 0], index[-1, -1]]
    return ClothLayout(positions, links, border, dict(corners=[int(i) for i in corners]))


def fold_corner(layout: ClothLayout, rows: int, cols: int, cells: int, gap: float,
                corner: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A rows x cols towel `layout` with one corner folded over onto the sheet, every drive at rest.

    `corner` indexes the towel's named corners, (-x,-y), (-x,+y), (+x,-y), (+x,+y). Counting grid cells
    (r, c) from that corner, the particles of the diagonal lines r + c < `cells` fold over the line
    r + c = `cells`, which stays flat: lines `cells` - 1 and `cells` - 2 make the fold's rounded edge
    (turned by alpha and pi - alpha about the fold line, with sin alpha = gap / (2 d), d = spacing / sqrt 2
    the distance between diagonal lines), the rest lie upside down `gap` (m) above the sheet, line
    `cells` - 3 - m over line `cells` + m, in the hollows between the sheet's particles (they sink into
    them when 2 radius < sqrt(d^2 + gap^2); they fall through the sheet when radius < d / 2, see
    `ClothConfig`). The rounded edge makes every turned particle meet its neighbours' drives where they
    do (each link's two frames at one point): a fold turned flat about the line through the particles
    of line `cells` pulls its hinge links 2.8 cm apart (at 2.5 cm spacing), and that jolt unfolded two
    of the four corners by itself. Returns local positions [N, 3] and orientations [N, 4] (wxyz)."""
    spacing = np.linalg.norm(layout.positions[1] - layout.positions[0])
    d = spacing / np.sqrt(2)
    sx, sy = (-1.0 if corner in (0, 1) else 1.0), (-1.0 if corner in (0, 2) else 1.0)
    r, c = np.divmod(np.arange(rows * cols), cols)
    line = (r if sx < 0 else rows - 1 - r) + (c if sy < 0 else cols - 1 - c)  # diagonal line from the corner
    into = np.array([-sx, -sy, 0.0]) / np.sqrt(2)  # horizontal, from the corner into the sheet
    axis = np.cross([0.0, 0.0, 1.0], into)  # turning about it by 0 < t < pi lifts the corner side up and over
    alpha = np.arcsin(gap / (2 * d))
    # walk the cross-section from the fold line's last flat joint: each line's particle sits half a link
    # past the previous joint, along its own turned direction, and the next joint half a link further
    turns, offsets, heights = {}, {}, {}
    joint = np.array([-d / 2, 0.0])  # (along `into` from line `cells`, up)
    for j in range(1, cells + 1):
        t = alpha if j == 1 else np.pi - alpha if j == 2 else np.pi
        half = d / 2 * np.array([-np.cos(t), np.sin(t)])
        turns[cells - j], (offsets[cells - j], heights[cells - j]) = t, joint + half
        joint = joint + 2 * half
    positions = layout.positions.copy()
    quats = np.tile([1.0, 0.0, 0.0, 0.0], (len(positions), 1))
    for i in np.nonzero(line < cells)[0]:
        k = line[i]
        positions[i] += (offsets[k] - (k - cells) * d) * into + [0.0, 0.0, heights[k]]
        quats[i] = [np.cos(turns[k] / 2), *(np.sin(turns[k] / 2) * axis)]
    return positions, quats


def fold_edge(layout: ClothLayout, rows: int, cols: int, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """A rows x cols towel `layout` with its -x edge strip folded back over the sheet along a grid line:
    row `cells` - 1 stands upright in the crease, rows below it lie one spacing above the sheet, upside
    down (row `cells` - 2 right above row `cells`). Every link keeps its rest length (the drives' frames
    meet), only the two links at the crease bend (by 90 degrees each), so the fold starts at rest but for
    bending. Returns local positions [N, 3] and orientations [N, 4] (wxyz)."""
    spacing = np.linalg.norm(layout.positions[1] - layout.positions[0])
    r = np.arange(rows * cols) // cols
    positions = layout.positions.copy()
    quats = np.tile([1.0, 0.0, 0.0, 0.0], (len(positions), 1))
    x_fold = layout.positions[cells * cols, 0]  # row `cells`: the first row left flat
    crease, top = r == cells - 1, r < cells - 1
    positions[crease, 0], positions[crease, 2] = x_fold - spacing / 2, positions[crease, 2] + spacing / 2
    quats[crease] = [np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0]  # a quarter turn about y
    positions[top, 0] = x_fold + (cells - 2 - r[top]) * spacing
    positions[top, 2] += spacing
    quats[top] = [0.0, 0.0, 1.0, 0.0]  # half a turn about y
    return positions, quats


def drape_over_rod(layout: ClothLayout, rows: int, cols: int, top_row: float,
                   wrap_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """A rows x cols towel `layout` hanging over a horizontal rod along y through the local origin: the
    sheet's point at row `top_row` (fractional: 4.5 lies between rows 4 and 5) on the rod's top, the rows
    near it on a circle of `wrap_radius` about the rod's axis (the rod's radius plus a particle's), the
    rest hanging straight down, rows below `top_row` on the -x side. Each particle is turned to the sheet's
    tangent and placed half a link past its neighbour's drive frame along it, so every drive starts at rest.
    Returns local positions [N, 3] and orientations [N, 4] (wxyz)."""
    spacing = np.linalg.norm(layout.positions[1] - layout.positions[0])
    # each row's turn about y: rows on the rod make a polygon about it whose corners (the drive frames) lie
    # on the tangents, half a link from each centre: centres on the circle, one link turns 2 atan(s / 2R);
    # a quarter turn once hanging
    step = 2 * np.arctan(spacing / (2 * wrap_radius))
    turn = np.clip((np.arange(rows) - top_row) * step, -np.pi / 2, np.pi / 2)
    tangent = np.stack([np.cos(turn), -np.sin(turn)], axis=1)  # (x, z) of each row's local +x
    first = int(np.ceil(top_row)) if top_row < rows - 1 else rows - 1  # walk from the row nearest the top
    centre = np.zeros((rows, 2))
    centre[first] = wrap_radius * np.array([np.sin(turn[first]), np.cos(turn[first])])
    for k in range(first + 1, rows):
        centre[k] = centre[k - 1] + spacing / 2 * (tangent[k - 1] + tangent[k])
    for k in range(first - 1, -1, -1):
        centre[k] = centre[k + 1] - spacing / 2 * (tangent[k + 1] + tangent[k])
    r = np.arange(rows * cols) // cols
    positions = layout.positions.copy()
    positions[:, 0], positions[:, 2] = centre[r, 0], centre[r, 1]
    quats = np.stack([np.cos(turn[r] / 2), np.zeros(len(r)), np.sin(turn[r] / 2), np.zeros(len(r))], axis=1)
    return positions, quats


def tent_panel(rows: int = 8, cols: int = 12, spacing: float = 0.03) -> ClothLayout:
    """A tent panel: a larger-spaced rectangle; `grommets` are its four corners (to pin on pegs)."""
    layout = towel(rows, cols, spacing)
    layout.named["grommets"] = layout.named.pop("corners")
    return layout


def shirt(body_rows: int = 8, body_cols: int = 6, sleeve_rows: int = 3, sleeve_cols: int = 3,
          spacing: float = ClothConfig.spacing) -> ClothLayout:
    """A T-shirt outline: a body (rows along x, collar at +x) with a sleeve on each side at the top.

    Named: `collar` (top edge), `hem` (bottom edge), `left_sleeve`, `right_sleeve` (all their particles).
    """
    rows, cols = body_rows, body_cols + 2 * sleeve_cols
    mask = np.zeros((rows, cols), bool)
    mask[:, sleeve_cols:sleeve_cols + body_cols] = True
    mask[rows - sleeve_rows:, :sleeve_cols] = True
    mask[rows - sleeve_rows:, -sleeve_cols:] = True
    positions, links, border, index = _grid(mask, spacing)
    named = dict(
        collar=index[-1, sleeve_cols:sleeve_cols + body_cols].tolist(),
        hem=index[0, sleeve_cols:sleeve_cols + body_cols].tolist(),
        left_sleeve=index[rows - sleeve_rows:, :sleeve_cols].ravel().tolist(),
        right_sleeve=index[rows - sleeve_rows:, -sleeve_cols:].ravel().tolist(),
    )
    return ClothLayout(positions, links, border, named)


def towel_with_loop(rows: int = 10, cols: int = 8, loop_particles: int = 7,
                    spacing: float = ClothConfig.spacing) -> ClothLayout:
    """A rectangular towel (`towel`) with a hanging loop at its (+x,+y) corner: a closed ring of
    `loop_particles` particles lying flat beyond the corner, a regular polygon of `loop_particles + 1`
    sides (one link each) through the corner, its centre on the corner's outward diagonal.

    Named: `corners` (as `towel`), `loop` (the ring in order round it, the corner first: a closed polygon,
    `loop_winding`'s ring); the ring's own particles are `cords` (drawn as beads of a cord)."""
    layout = towel(rows, cols, spacing)
    corner = layout.named["corners"][3]
    sides = loop_particles + 1
    radius = spacing / (2 * np.sin(np.pi / sides))  # a regular polygon with sides one link long
    outward = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    centre = layout.positions[corner] + radius * outward
    start = np.arctan2(-outward[1], -outward[0])  # the corner's angle about the centre
    angles = start + 2 * np.pi * np.arange(1, sides) / sides
    ring = centre + radius * np.stack([np.cos(angles), np.sin(angles), np.zeros(loop_particles)], axis=1)
    n = len(layout.positions)
    ids = list(range(n, n + loop_particles))
    chain = [corner] + ids + [corner]
    links = layout.links + list(zip(chain[:-1], chain[1:]))
    named = dict(layout.named, loop=[corner] + ids)
    return ClothLayout(np.concatenate([layout.positions, ring]), links, layout.border, named, cords=set(ids))


def bag(rows: int = 6, cols: int = 6, handle_length: int = 5, spacing: float = ClothConfig.spacing,
        radius: float = ClothConfig.radius) -> ClothLayout:
    """A tote bag lying flat: back panel on the table, front panel on top of it (2.2 radii higher),
    sewn along both sides (y edges) and the bottom (-x edge); the top (+x) is the opening. Each panel
    has a handle: an arc of `handle_length` particles from its top corners, lying flat beyond the top.

    Named: `front_handle`, `back_handle` (handle particles), `front_rim`, `back_rim` (top edges).
    """
    gap = 2.2 * radius
    mask = np.ones((rows, cols), bool)
    back, back_links, back_border, back_index = _grid(mask, spacing, z=0.0)
    front, front_links, front_border, front_index = _grid(mask, spacing, z=gap, offset=rows * cols)
    positions = [back, front]
    links = back_links + front_links
    seam = back_index[:, 0].tolist() + back_index[:, -1].tolist() + back_index[0, 1:-1].tolist()
    links += [(i, i + rows * cols) for i in seam]
    named = dict(front_rim=front_index[-1].tolist(), back_rim=back_index[-1].tolist())
    n = 2 * rows * cols
    top_x = back[back_index[-1, 0], 0]
    half_width = (cols - 1) / 2 * spacing
    # handle arc: a half ellipse from one top corner to the other, beyond the opening
    angles = np.linspace(0, np.pi, handle_length + 2)[1:-1]
    for panel, index, z in (("back", back_index, 0.0), ("front", front_index, gap)):
        arc = np.stack([top_x + 2.5 * spacing * np.sin(angles), -half_width * np.cos(angles), np.full(handle_length, z)], axis=1)
        ids = list(range(n, n + handle_length))
        chain = [int(index[-1, 0])] + ids + [int(index[-1, -1])]
        links += list(zip(chain[:-1], chain[1:]))
        named[f"{panel}_handle"] = ids
        positions.append(arc)
        n += handle_length
    handles = set(range(2 * rows * cols, n))
    return ClothLayout(np.concatenate(positions), links, back_border | front_border, named, cords=handles)


class Cloth(SphereSet):
    """A built sheet: its particles (a `SphereSet`), the `drives` linking them and the `layout` it was made from."""

    def __init__(self, spheres: list[Actor], name: str, drives: list, layout: ClothLayout, config: ClothConfig):
        super().__init__(spheres, name)
        self.drives = drives
        self.layout = layout
        self.config = config

    def corner_spheres(self) -> list[Actor]:
        """The particles (actors) the layout names `corners`, in its order (a towel's: (-x,-y), (-x,+y),
        (+x,-y), (+x,+y))."""
        return [self.spheres[i] for i in self.layout.named["corners"]]

    def set_rest_shape(self, pose: Pose):
        """Lay the sheet in its rest shape at `pose` (batched over the envs being reset), at rest."""
        self.set_shape(torch.as_tensor(self.layout.positions, dtype=torch.float32, device=pose.device), None, pose)

    def set_shape(self, local: torch.Tensor, local_q: Optional[torch.Tensor], pose: Pose):
        """Lay the sheet at `pose` [b] (the envs being reset) in a shape given in its local frame, at rest:
        particle positions `local` [N, 3] or [b, N, 3] and orientations `local_q` [N, 4] or [b, N, 4]
        (wxyz; None: unturned), e.g. `fold_corner`'s."""
        n, b = len(self.spheres), pose.p.shape[0]
        local = torch.as_tensor(local, dtype=torch.float32, device=pose.device).expand(b, n, 3)
        world = pose.to_transformation_matrix()  # [b, 4, 4]
        xyz = torch.einsum("bij,bnj->nbi", world[:, :3, :3], local) + world[None, :, :3, 3]
        q = pose.q[None].expand(n, b, 4)
        if local_q is not None:
            local_q = torch.as_tensor(local_q, dtype=torch.float32, device=pose.device).expand(b, n, 4)
            q = quaternion_multiply(q, local_q.transpose(0, 1))
        self.place(xyz.reshape(-1, 3), q.reshape(-1, 4))


def build_cloth(scene: ManiSkillScene, name: str, layout: ClothLayout, config: ClothConfig = ClothConfig()) -> Cloth:
    """Build the sheet of `layout` (particles `<name>_<i>`); place it with `Cloth.set_rest_shape`."""
    material = physx.PhysxMaterial(config.friction, config.friction, 0.0)
    density = config.particle_mass / (4 / 3 * np.pi * config.radius**3)
    half = config.spacing / 2 * 1.04  # tiles overlap a little, so a bent sheet shows no gaps
    tile = [half, half, config.tile_thickness]
    if scene.can_render():
        colors = {
            kind: sapien.render.RenderMaterial(base_color=list(color), roughness=0.9)
            for kind, color in (("inner", config.color), ("border", config.border_color))
        }

    def add_visual(builder, i: int):
        if i in layout.cords:
            builder.add_sphere_visual(radius=config.radius, material=colors["border"])
        else:
            builder.add_box_visual(half_size=tile, material=colors["border" if i in layout.border else "inner"])

    spheres = build_spheres(scene, name, layout.positions, config.radius, material, density, CONTACT_OFFSET, add_visual)
    for sphere in spheres:
        for body in sphere._bodies:
            if config.solver_position_iterations:
                body.set_solver_position_iterations(config.solver_position_iterations)
            if config.max_depenetration_velocity:
                body.set_max_depenetration_velocity(config.max_depenetration_velocity)
            if config.max_linear_velocity:
                body.set_max_linear_velocity(config.max_linear_velocity)
    drives = [_link(scene, spheres, layout.positions, i, j, config, cord=i in layout.cords or j in layout.cords)
              for i, j in layout.links]
    return Cloth(spheres, name, drives, layout, config)


def _link(scene: ManiSkillScene, particles: list[Actor], rest: np.ndarray, i: int, j: int, config: ClothConfig,
          cord: bool = False):
    """A D6 drive between particles i and j with both frames at their rest midpoint (`cord`: a link of a cord
    particle, bent with the config's cord drive where it sets one)."""
    mid = (rest[i] + rest[j]) / 2
    drive = scene.create_drive(particles[i], sapien.Pose(p=mid - rest[i]), particles[j], sapien.Pose(p=mid - rest[j]))
    drive.set_drive_property_x(config.stretch_stiffness, config.stretch_damping)
    drive.set_drive_property_y(config.stretch_stiffness, config.stretch_damping)
    drive.set_drive_property_z(config.stretch_stiffness, config.stretch_damping)
    for component in drive._objs:  # ManiSkill's Drive wraps only the linear drive properties
        stiffness, damping = config.bend_stiffness, config.bend_damping
        if cord:
            stiffness = config.cord_bend_stiffness or stiffness
            damping = config.cord_bend_damping or damping
        component.set_drive_property_slerp(stiffness, damping)
    return drive


# ---- metrics (footprints: `maniladder_ms.deformables.metrics`, with tile = config.spacing) -----------
def fold_pairs(rows: int, cols: int, axis: int = 0) -> list[tuple[int, int]]:
    """Particle pairs of a rows x cols towel that meet when it is folded in half across `axis`
    (0: the fold line runs along y, halving the rows; 1: along x, halving the columns)."""
    index = np.arange(rows * cols).reshape(rows, cols)
    if axis == 1:
        index = index.T
    half = index.shape[0] // 2
    return list(zip(index[:half].ravel().tolist(), index[::-1][:half].ravel().tolist()))


def diagonal_fold_pairs(size: int, anti: bool = False) -> list[tuple[int, int]]:
    """Particle pairs of a size x size square sheet (a napkin, `towel(size, size)`) that meet when it is
    folded along a diagonal into a triangle: the fold line through corners (-x,-y) and (+x,+y) (its grid
    cells r = c) mirrors cell (r, c) onto (c, r), bringing corner (-x,+y) onto (+x,-y); with `anti` the
    fold line through (-x,+y) and (+x,-y) (r + c = size - 1) mirrors (r, c) onto (size-1-c, size-1-r),
    bringing corner (-x,-y) onto (+x,+y). Particles on the fold line pair with nobody: size (size - 1) / 2
    pairs, the first particle of each on the side of the corner with the lower index."""
    index = np.arange(size * size).reshape(size, size)
    r, c = np.divmod(np.arange(size * size), size)
    if anti:
        mine, partner = r + c < size - 1, index[size - 1 - c, size - 1 - r]
    else:
        mine, partner = r < c, index[c, r]
    return list(zip(np.nonzero(mine)[0].tolist(), partner[mine].tolist()))


def fold_distance(points: torch.Tensor, pairs: list[tuple[int, int]], top_down: bool = False) -> torch.Tensor:
    """Mean distance (m) between the particles of each pair, [B]: 0 when the fold is perfect.

    `top_down`: the distance seen from above (x, y only). A sheet of particles folded onto itself keeps
    its two layers about two particle radii apart (2 cm at radius 10 mm: a layer resting right above the
    other, or 1.6-2 cm nested in its hollows), so the full distance of a perfect fold is that thickness;
    seen from above it is 0 when each particle lies over its partner."""
    a, b = zip(*pairs)
    d = points[:, list(a)] - points[:, list(b)]
    if top_down:
        d = d[..., :2]
    return torch.linalg.norm(d, dim=-1).mean(dim=1)


def flatness(points: torch.Tensor) -> torch.Tensor:
    """Standard deviation (m) of the particle heights, [B]: 0 for a sheet lying flat."""
    return points[..., 2].std(dim=1, unbiased=False)


def fraction_below(points: torch.Tensor, height: float) -> torch.Tensor:
    """Fraction of particles lower than `height`, [B] (e.g. hanging below a bar)."""
    return (points[..., 2] < height).float().mean(dim=1)


def fraction_beyond(points: torch.Tensor, point: torch.Tensor, normal: torch.Tensor) -> torch.Tensor:
    """Fraction of particles on the side of the plane through `point` [3] facing `normal` [3], [B]
    (with a vertical plane through a bar: the share of the sheet on that side of the bar)."""
    return (((points - point) * normal).sum(dim=-1) > 0).float().mean(dim=1)


def hanging_fractions(points: torch.Tensor, bar_point: torch.Tensor, bar_axis: torch.Tensor,
                      bar_top: torch.Tensor | float) -> torch.Tensor:
    """Fractions of particles hanging on each side of a horizontal bar, [B, 2]: a particle hangs on a
    side if it lies beyond the vertical plane through the bar's axis on that side (column 0: the side
    the horizontal normal `bar_axis x z` points away from, column 1: the side it points to; a bar along +y:
    -x, +x) and lower
    than the bar's top `bar_top` ([B] or a float; particles over the bar count for neither side).
    `points` [B, N, 3]; `bar_point` [B, 3] a point on the bar's axis; `bar_axis` [B, 3] or [3] its
    direction. A towel draped symmetrically over the bar gives about (0.5, 0.5); one lying flat on the
    table on one side gives 1 on that side and 0 on the other."""
    axis = torch.as_tensor(bar_axis, dtype=points.dtype, device=points.device).expand(points.shape[0], 3)
    normal = torch.stack([axis[:, 1], -axis[:, 0], torch.zeros_like(axis[:, 0])], dim=1)  # bar_axis x z
    normal = torch.nn.functional.normalize(normal, dim=1)
    signed = ((points - bar_point[:, None]) * normal[:, None]).sum(dim=-1)  # [B, N]
    top = torch.as_tensor(bar_top, dtype=points.dtype, device=points.device)
    below = points[..., 2] < (top[:, None] if top.dim() else top)
    return torch.stack([((signed < 0) & below).float().mean(dim=1), ((signed > 0) & below).float().mean(dim=1)],
                       dim=1)


def loop_winding(points: torch.Tensor, ring: list[int], point: torch.Tensor, axis: torch.Tensor) -> torch.Tensor:
    """How many times the closed polygon of particles `ring` (in order round it) winds about the line through
    `point` [B, 3] along `axis` [B, 3] or [3], [B] (signed; ~0 for a ring beside the line, +-1 for a ring
    round it): the sum of the turns between consecutive ring particles seen along the axis, over 2 pi.
    `points` [B, N, 3]."""
    axis = torch.nn.functional.normalize(
        torch.as_tensor(axis, dtype=points.dtype, device=points.device).expand(points.shape[0], 3), dim=1)
    # a basis (u, v) of the plane across the axis
    helper = torch.where(axis[:, 2:].abs() < 0.9, torch.tensor([0.0, 0.0, 1.0], device=points.device),
                         torch.tensor([1.0, 0.0, 0.0], device=points.device))
    u = torch.nn.functional.normalize(torch.linalg.cross(axis, helper), dim=1)
    v = torch.linalg.cross(axis, u)
    rel = points[:, ring] - point[:, None]
    angle = torch.atan2((rel * v[:, None]).sum(-1), (rel * u[:, None]).sum(-1))  # [B, K]
    turn = torch.diff(torch.cat([angle, angle[:, :1]], dim=1), dim=1)
    turn = torch.remainder(turn + torch.pi, 2 * torch.pi) - torch.pi
    return turn.sum(dim=1) / (2 * torch.pi)


def loop_on_hook(points: torch.Tensor, ring: list[int], tip: torch.Tensor, axis: torch.Tensor,
                 length: float | torch.Tensor) -> torch.Tensor:
    """Whether the loop `ring` (`loop_winding`'s) hangs on a straight hook of `length` m whose shaft points
    along `axis` [B, 3] or [3] (out of its wall) to its `tip` [B, 3], [B] bool: the ring winds once round
    the shaft's line (|winding| > 1/2) and the ring's centre (mean of its particles) lies along the shaft,
    between the wall (`length` behind the tip) and the tip: encircling the tip, not beyond it."""
    axis = torch.nn.functional.normalize(
        torch.as_tensor(axis, dtype=points.dtype, device=points.device).expand(points.shape[0], 3), dim=1)
    along = ((points[:, ring].mean(dim=1) - tip) * axis).sum(dim=1)  # <= 0: behind the tip
    return (loop_winding(points, ring, tip, axis).abs() > 0.5) & (along <= 0) & (along >= -torch.as_tensor(length))


def grid_yaw(points: torch.Tensor, links: list[tuple[int, int]]) -> torch.Tensor:
    """Yaw (rad, modulo pi/2) of a grid sheet's axes, [B]: the mean direction of its links' top-down
    vectors, each weighted by its horizontal length, with angles taken four times (grid links point
    along yaw + k pi/2, and so do those of a layer folded over about a diagonal)."""
    i, j = map(list, zip(*links))
    d = points[:, j, :2] - points[:, i, :2]
    angle, weight = torch.atan2(d[..., 1], d[..., 0]), torch.linalg.norm(d, dim=-1)
    return torch.atan2((weight * torch.sin(4 * angle)).sum(dim=1), (weight * torch.cos(4 * angle)).sum(dim=1)) / 4


def coverage(points: torch.Tensor, layout: ClothLayout, spacing: float) -> torch.Tensor:
    """Top-down area a grid sheet covers over its flat area (N * spacing^2), [B]: `metrics.footprint_area`
    with the points turned by -`grid_yaw`, so the square tiles line up with the sheet (a flat sheet
    covers 1.0 whatever its yaw; a towel with 15 of its 100 particles folded over 0.85)."""
    yaw = grid_yaw(points, layout.links)
    cos, sin = torch.cos(-yaw)[:, None], torch.sin(-yaw)[:, None]
    x, y = points[..., 0], points[..., 1]
    turned = torch.stack([cos * x - sin * y, sin * x + cos * y, points[..., 2]], dim=-1)
    return footprint_area(turned, spacing) / (len(layout.positions) * spacing**2)
