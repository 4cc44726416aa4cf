"""Occupancy metrics shared by cloth, clay and rope: top-down footprints and voxel grids of particle sets,
and the share of a rope's points inside a channel.

Each particle counts as a square tile (or cube) of side `tile` centred on it, rasterised on a grid of
`cell` (default tile / 2); all functions are batched over the leading env dimension of points [B, N, 3].
- `footprint_area`: area (m^2) the particles cover seen from above;
- `footprint_grid` + `iou`: shape agreement with a target footprint given as a boolean grid;
- `region_coverage`: fraction of a table rectangle that the particles cover;
- `target_coverage`: the same for a rectangle placed per env (a target area marked on the table);
- `voxel_grid` + `iou`: 3D shape agreement;
- `inside_channel_fraction`: share of points (a rope's capsule centres) inside a straight channel on the table;
- `inside_star`: whether points lie inside a star outline (a stamp's footprint, `clay.imprint_iou`).
"""

from __future__ import annotations

import numpy as np
import torch


def _tile_samples(points: torch.Tensor, tile: float, cell: float, dims: int) -> torch.Tensor:
    """Integer cells [B, N * k^dims, dims] covered by each particle's tile, sampled k = tile / cell times per axis."""
    k = max(1, int(round(tile / cell)))
    offsets = (torch.arange(k, device=points.device, dtype=points.dtype) + 0.5) * (tile / k) - tile / 2
    grid = torch.stack(torch.meshgrid(*[offsets] * dims, indexing="ij"), dim=-1).reshape(-1, dims)
    samples = points[:, :, None, :dims] + grid[None, None]
    return torch.floor(samples.reshape(points.shape[0], -1, dims) / cell).long()


def _occupancy(cells: torch.Tensor, lo: torch.Tensor, size: tuple[int, ...]) -> torch.Tensor:
    """[B, *size] boolean grid of the cells (relative to cell index `lo`) that fall inside it."""
    rel = cells - lo
    ok = ((rel >= 0) & (rel < torch.tensor(size, device=cells.device))).all(dim=-1)
    b = torch.arange(cells.shape[0], device=cells.device)[:, None].expand_as(ok)
    grid = torch.zeros((cells.shape[0], *size), dtype=torch.bool, device=cells.device)
    grid[(b[ok], *rel[ok].unbind(-1))] = True
    return grid


def _region_cells(region, cell: float) -> tuple[torch.Tensor, tuple[int, ...]]:
    """Lowest cell index and grid size of region (lo_0, hi_0, lo_1, hi_1, ...)."""
    lo = [int(np.floor(region[2 * d] / cell)) for d in range(len(region) // 2)]
    size = tuple(int(np.ceil(region[2 * d + 1] / cell)) - lo[d] for d in range(len(region) // 2))
    return torch.tensor(lo), size


def footprint_grid(points: torch.Tensor, tile: float, region: tuple[float, float, float, float], cell: float = None) -> torch.Tensor:
    """[B, H, W] top-down occupancy of the table rectangle region = (xmin, xmax, ymin, ymax)."""
    cell = tile / 2 if cell is None else cell
    lo, size = _region_cells(region, cell)
    return _occupancy(_tile_samples(points, tile, cell, 2), lo.to(points.device), size)


def footprint_area(points: torch.Tensor, tile: float, cell: float = None) -> torch.Tensor:
    """Top-down area (m^2) covered by the particles, [B]; N separate particles cover N * tile^2."""
    cell = tile / 2 if cell is None else cell
    cells = _tile_samples(points, tile, cell, 2)
    lo = cells.amin(dim=(0, 1))
    size = tuple((cells.amax(dim=(0, 1)) - lo + 1).tolist())
    return _occupancy(cells, lo, size).flatten(1).sum(dim=1) * cell**2


def region_coverage(points: torch.Tensor, tile: float, region: tuple[float, float, float, float], cell: float = None) -> torch.Tensor:
    """Fraction of the table rectangle region = (xmin, xmax, ymin, ymax) covered from above, [B]."""
    return footprint_grid(points, tile, region, cell).flatten(1).float().mean(dim=1)


def target_coverage(points: torch.Tensor, tile: float, center: torch.Tensor, half_size: tuple[float, float],
                    max_height: float = None, cell: float = None) -> torch.Tensor:
    """Fraction of the table rectangle of half sizes `half_size` (x, y) centred at `center` [B, 2+] (one per
    env, axis-aligned) covered from above, [B]; with `max_height`, particles higher up (lifted off the
    table) do not count."""
    rel = points - torch.nn.functional.pad(center[:, None, :2], (0, 1))
    if max_height is not None:
        rel = torch.where((points[..., 2:] > max_height), torch.full_like(rel, 1e3), rel)
    hx, hy = half_size
    return region_coverage(rel, tile, (-hx, hx, -hy, hy), cell)


def voxel_grid(points: torch.Tensor, tile: float, region: tuple[float, ...], cell: float = None) -> torch.Tensor:
    """[B, X, Y, Z] occupancy of the box region = (xmin, xmax, ymin, ymax, zmin, zmax), each particle a cube."""
    cell = tile / 2 if cell is None else cell
    lo, size = _region_cells(region, cell)
    return _occupancy(_tile_samples(points, tile, cell, 3), lo.to(points.device), size)


def iou(grid: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Intersection over union of boolean grids [B, ...] and a target of the same grid shape, [B]."""
    target = target.to(grid.device).expand_as(grid)
    inter = (grid & target).flatten(1).sum(dim=1)
    union = (grid | target).flatten(1).sum(dim=1).clamp_min(1)
    return inter / union


def inside_channel_fraction(points: torch.Tensor, centre: torch.Tensor, yaw: torch.Tensor, half_width: float,
                            half_length: float, top: float) -> torch.Tensor:
    """Fraction of `points` [B, N, 3] inside a straight channel (a groove, a U-shaped slot), [B].

    The channel runs along world yaw `yaw` [B] (its axis direction in the table plane) through `centre` [B, 2+]
    (the middle of its axis); a point is inside when it lies between its walls (at most `half_width` from the
    axis, sideways), between its ends (at most `half_length` from `centre` along the axis) and below the walls'
    top (z at most `top`, world)."""
    along, across = channel_coords(points, centre, yaw)
    inside = (across.abs() <= half_width) & (along.abs() <= half_length) & (points[..., 2] <= top)
    return inside.float().mean(dim=1)


def channel_coords(points: torch.Tensor, centre: torch.Tensor, yaw: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Top-down coordinates of `points` [B, N, 2+] in a straight channel's frame (`inside_channel_fraction`): the
    distance along its axis from `centre` [B, 2+] and the signed distance across it (left of the axis positive),
    each [B, N]."""
    rel = points[..., :2] - centre[:, None, :2]
    c, s = torch.cos(yaw)[:, None], torch.sin(yaw)[:, None]
    return rel[..., 0] * c + rel[..., 1] * s, -rel[..., 0] * s + rel[..., 1] * c


def inside_star(xy: torch.Tensor, outer: float, inner: float, arms: int) -> torch.Tensor:
    """Whether points xy [..., 2] (in the star's own frame) lie inside a star outline of `arms` tips at radius
    `outer` (tip k at angle 2 pi k / arms) with the valleys between them at radius `inner`, [...]."""
    sector = 2 * np.pi / arms
    # fold every point into the half sector between a tip (angle 0) and its valley (angle sector / 2)
    angle = torch.remainder(torch.atan2(xy[..., 1], xy[..., 0]) + sector / 2, sector) - sector / 2
    radius = torch.linalg.norm(xy, dim=-1)
    x, y = radius * torch.cos(angle), radius * torch.sin(angle).abs()
    valley_x, valley_y = inner * np.cos(sector / 2), inner * np.sin(sector / 2)
    # inside: on the centre's side of the edge from the tip (outer, 0) to the valley
    cross = (valley_x - outer) * y - valley_y * (x - outer)
    return cross >= 0
