"""A shirt as a cloth proxy: `cloth.shirt`'s T-shaped sheet (a body with a sleeve on each side at its top), its
folds and its measures. The shirt tasks (UnfoldShirt, FoldShirt) share this module; `cloth.py` does not import it.

What the proxy is: one layer of particles on a 2.5 cm grid (`cloth.shirt`: body rows along its local x, collar
at +x, hem at -x; the `left_sleeve` at -y, the `right_sleeve` at +y, each `sleeve_rows` x `sleeve_cols` particles
beside the body's top rows), linked by `cloth`'s spring drives. It is a flat T, front and back in one layer: there
is no tube, no neck opening, no inside. A fold is the sheet lying on itself: particles not linked to each other
collide, so a folded sleeve rests on the body (with particles of 10 mm radius: `cloth.ClothConfig`) and can be
peeled off it again; the bending drives are soft, so a fold stays where it is laid and a sleeve hangs when lifted.

- `fold`: a folded shirt, sleeves folded over onto the body along the seam, the hem strip folded up over the
  body (every drive at rest but for the two crease links of each folded row or column);
- `body_frame`: where the body lies now (centre, its hem-to-collar axis and the axis across it);
- `sleeve_out`: how far each sleeve's cuff lies beyond the body's side edge (> 0: out, seen from above);
- `flat_place`, `local_place`: where particles (or points of the rest frame) would lie if the shirt lay flat
  around its body as it lies now;
- `outline_excess`: how far particles (a sleeve's) reach beyond the body's outline;
- `hem_collar_pairs`: the particles a fold of the body in half (hem onto collar) lays together.
"""

from __future__ import annotations

import numpy as np
import torch

from . import cloth

SIDES = ("left", "right")  # the sleeves, as `cloth.shirt` names them: left at the shirt's local -y, right at +y
SIDE_SIGN = {"left": -1.0, "right": 1.0}  # sign of a sleeve's local y


def sleeve_ids(layout: cloth.ClothLayout, side: str) -> list[int]:
    """The particle indices of one sleeve (`cloth.shirt`'s `left_sleeve` / `right_sleeve`)."""
    return list(layout.named[f"{side}_sleeve"])


def body_ids(layout: cloth.ClothLayout) -> list[int]:
    """The particle indices of the body: every particle of no sleeve."""
    sleeves = set(sleeve_ids(layout, "left")) | set(sleeve_ids(layout, "right"))
    return [i for i in range(len(layout.positions)) if i not in sleeves]


def spacing_of(layout: cloth.ClothLayout) -> float:
    """The grid spacing (m) of a `cloth.shirt` layout (its first two particles are row neighbours)."""
    return float(np.linalg.norm(layout.positions[1] - layout.positions[0]))


def body_half_width(layout: cloth.ClothLayout) -> float:
    """Half the body's width (m) to its outline: its outermost particle centres plus half a tile."""
    return float(np.abs(layout.positions[body_ids(layout), 1]).max()) + spacing_of(layout) / 2


def cuff_ids(layout: cloth.ClothLayout, side: str) -> list[int]:
    """A sleeve's cuff: its outermost column of particles (furthest from the body), ordered hem to collar."""
    ids = sleeve_ids(layout, side)
    y = layout.positions[ids, 1] * SIDE_SIGN[side]
    cuff = [i for i, v in zip(ids, y) if np.isclose(v, y.max())]
    return sorted(cuff, key=lambda i: layout.positions[i, 0])


def fold(layout: cloth.ClothLayout, hem_cells: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The shirt `layout` with both sleeves folded over onto the body along the seam and, with `hem_cells` > 0,
    the body's hem strip folded up over the body, every link at its rest length.

    Sleeves: the sleeve column next to the body stands upright in the crease (a quarter turn about x, its centre
    half a spacing in from the seam column and half a spacing up), the sleeve's other columns lie upside down
    (half a turn about x) one spacing above the body, the column after the crease right above the body's edge
    column, the cuff one column further in. Hem (as `cloth.fold_edge`'s edge strip): body row `hem_cells` - 1
    stands upright in the crease, the rows below it lie upside down one spacing above the body, row
    `hem_cells` - 2 right above row `hem_cells`; with `hem_cells` <= body rows - sleeve rows - 1 (3 for the
    default shirt) the hem lands on rows below the sleeves, so no layer lies on another folded layer. Only the
    two links at each crease bend (90 degrees each); the folded layers sink from one spacing (2.5 cm) to two
    particle radii above the body in the first steps. Returns local positions [N, 3] and orientations [N, 4]
    (wxyz)."""
    spacing = spacing_of(layout)
    positions = layout.positions.copy()
    quats = np.tile([1.0, 0.0, 0.0, 0.0], (len(positions), 1))
    edge = body_half_width(layout) - spacing / 2  # |y| of the body's edge column
    for side in SIDES:
        sign = SIDE_SIGN[side]
        for i in sleeve_ids(layout, side):
            k = int(round((abs(layout.positions[i, 1]) - edge) / spacing))  # 1: the column next to the body
            if k == 1:
                positions[i, 1], positions[i, 2] = sign * (edge + spacing / 2), positions[i, 2] + spacing / 2
                turn = sign * np.pi / 2  # the sleeve's outward direction turned to point up
                quats[i] = [np.cos(turn / 2), np.sin(turn / 2), 0.0, 0.0]
            else:
                positions[i, 1], positions[i, 2] = sign * (edge - (k - 2) * spacing), positions[i, 2] + spacing
                quats[i] = [0.0, 1.0, 0.0, 0.0]
    if hem_cells:
        body = body_ids(layout)
        hem_x = layout.positions[body, 0].min()
        row = {i: int(round((layout.positions[i, 0] - hem_x) / spacing)) for i in body}
        x_fold = hem_x + hem_cells * spacing  # row `hem_cells`: the first row left flat
        for i, r in row.items():
            if r == hem_cells - 1:
                positions[i, 0], positions[i, 2] = x_fold - spacing / 2, positions[i, 2] + spacing / 2
                quats[i] = [np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0]  # a quarter turn about y
            elif r < hem_cells - 1:
                positions[i, 0], positions[i, 2] = x_fold + (hem_cells - 2 - r) * spacing, positions[i, 2] + spacing
                quats[i] = [0.0, 0.0, 1.0, 0.0]  # half a turn about y
    return positions, quats


def frame_ids(layout: cloth.ClothLayout) -> list[int]:
    """The body particles the shirt's pose is read from (`body_frame`): the body's collar half (rest x > 0),
    where the sleeves join, which no fold of `fold` moves."""
    return [i for i in body_ids(layout) if layout.positions[i, 0] > 0]


def body_frame(points: torch.Tensor, layout: cloth.ClothLayout) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Where the body lies now, seen from above, of particle positions `points` [B, N, 3], read from its collar
    half (`frame_ids`: a folded hem does not move it): that half's centre [B, 2] (mean of its particles), the
    body's hem-to-collar axis [B, 2] (the least-squares rotation taking the half's rest positions onto its
    current ones, so one bunched row alone does not turn it) and the axis across it [B, 2] (the along axis
    turned a quarter turn counter-clockwise: the right sleeve's side)."""
    ids = frame_ids(layout)
    rest = torch.as_tensor(layout.positions[ids, :2], dtype=points.dtype, device=points.device)
    rest = rest - rest.mean(dim=0)
    now = points[:, ids, :2]
    centre = now.mean(dim=1)
    rel = now - centre[:, None]
    # 2D Procrustes: the angle maximising sum(rel . R rest)
    dot = (rel * rest).sum(dim=(1, 2))
    cross = (rest[None, :, 0] * rel[..., 1] - rest[None, :, 1] * rel[..., 0]).sum(dim=1)
    angle = torch.atan2(cross, dot)
    along = torch.stack([torch.cos(angle), torch.sin(angle)], dim=1)
    across = torch.stack([-along[:, 1], along[:, 0]], dim=1)
    return centre, along, across


def sleeve_out(points: torch.Tensor, layout: cloth.ClothLayout, side: str) -> torch.Tensor:
    """How far (m) the sleeve's cuff lies beyond the body's side edge on its own side, seen from above, [B]: the
    least outward offset across the body (`body_frame`) of the cuff's particles, less the body's half width.
    > 0: every cuff particle lies outside the body's outline (flat: 2.5 spacings, 6.25 cm at 2.5 cm spacing); a
    sleeve folded over onto the body: -1.5 spacings (-3.9 cm measured)."""
    centre, _, across = body_frame(points, layout)
    cuff = points[:, cuff_ids(layout, side), :2] - centre[:, None]
    outward = SIDE_SIGN[side] * (cuff * across[:, None]).sum(dim=-1)
    return outward.amin(dim=1) - body_half_width(layout)


def local_place(points: torch.Tensor, layout: cloth.ClothLayout, local_xy: np.ndarray) -> torch.Tensor:
    """Where points given in the shirt's rest frame `local_xy` [k, 2] (m; its layout's frame) lie with the body as it
    lies now (`body_frame`), seen from above, [B, k, 2]."""
    centre, along, across = body_frame(points, layout)
    origin = layout.positions[frame_ids(layout), :2].mean(axis=0)
    rest = torch.as_tensor(np.asarray(local_xy) - origin, dtype=points.dtype, device=points.device)
    return centre[:, None] + rest[None, :, :1] * along[:, None] + rest[None, :, 1:] * across[:, None]


def flat_place(points: torch.Tensor, layout: cloth.ClothLayout, ids: list[int]) -> torch.Tensor:
    """Where the particles `ids` lie when the shirt lies flat around its body as the body lies now (`body_frame`
    applied to their rest positions), seen from above, [B, len(ids), 2]."""
    centre, along, across = body_frame(points, layout)
    rest = torch.as_tensor(layout.positions[:, :2], dtype=points.dtype, device=points.device)
    rest = rest[ids] - rest[frame_ids(layout)].mean(dim=0)
    return centre[:, None] + rest[None, :, :1] * along[:, None] + rest[None, :, 1:] * across[:, None]


def outline_excess(points: torch.Tensor, layout: cloth.ClothLayout, ids: list[int]) -> torch.Tensor:
    """How far (m) the particles `ids` reach beyond the body's outline seen from above, [B]: the largest distance,
    along or across the body (`body_frame`), by which a particle centre lies outside the rectangle of the body's
    rest outline (its particle centres plus half a tile); <= 0 when all lie within it."""
    spacing = spacing_of(layout)
    body = layout.positions[body_ids(layout), :2]
    lo, hi = body.min(axis=0) - spacing / 2, body.max(axis=0) + spacing / 2
    centre, along, across = body_frame(points, layout)
    origin = layout.positions[frame_ids(layout), :2].mean(axis=0)
    rel = points[:, ids, :2] - centre[:, None]
    local = torch.stack([(rel * along[:, None]).sum(-1), (rel * across[:, None]).sum(-1)], dim=-1)
    local = local + torch.as_tensor(origin, dtype=points.dtype, device=points.device)
    lo_t = torch.as_tensor(lo, dtype=points.dtype, device=points.device)
    hi_t = torch.as_tensor(hi, dtype=points.dtype, device=points.device)
    return torch.maximum(lo_t - local, local - hi_t).amax(dim=-1).amax(dim=1)


def hem_collar_pairs(layout: cloth.ClothLayout) -> list[tuple[int, int]]:
    """The (hem, collar) particle pairs of each body column: they lie together when the body is folded in half,
    hem onto collar."""
    hem = sorted(layout.named["hem"], key=lambda i: layout.positions[i, 1])
    collar = sorted(layout.named["collar"], key=lambda i: layout.positions[i, 1])
    return list(zip(hem, collar))


def draw_pose(b: int, x_range, max_y: float, max_yaw: float, rest_z: float):
    """The shirt tasks' start pose of `b` shirts (torch's default device): yaw uniform in +-`max_yaw` (deg), x
    uniform in `x_range`, y in +-`max_y`, lying at `rest_z`; drawn in that order (seeds keep their layouts)."""
    from mani_skill.utils.structs.pose import Pose

    from maniladder_ms.geometry import yaw_quat
    from maniladder_ms.layout import symmetric_deg, uniform

    yaw = symmetric_deg(b, max_yaw)
    xyz = torch.stack([uniform(b, x_range), (torch.rand(b) * 2 - 1) * max_y, torch.full((b,), rest_z)], dim=1)
    return Pose.create_from_pq(xyz, yaw_quat(yaw))
