"""A bag as a cloth proxy: an open pouch of two particle panels sewn along three edges, and whether a point lies
inside it. OpenBagAndInsert uses this module; `cloth.py` does not import it.

What the proxy is: `pouch` lays two `rows` x `cols` grids of particles (`cloth`'s sheet: spheres linked by spring
drives) one on the other, the back panel on the table and the front panel 2.2 radii above it, and links them
along both sides (the first and last column) and the bottom (the first row): a flat bag lying on its back, its
mouth (the last row of each panel, `front_rim` / `back_rim`) open at the local +x edge. Unlike `cloth.bag` it has
no handles: nothing lies beyond the mouth. Lying flat the bag is closed: the front panel rests on the back one, so
a cube dropped on it stays on top; lifting the front rim opens the mouth into a pocket between the panels. A cube
cannot pass through a panel: the gap between two neighbouring particles is the spacing less two radii (9 mm at
2.5 cm and 8 mm), the hole in the middle of a grid cell spacing sqrt 2 less two radii (19 mm).

- `bag_frame`: where the back panel lies now (its centre, the bottom-to-mouth axis, the axis across, its normal
  towards the front panel) and the mouth's, the bottom's and the sides' places along those axes;
- `inside`: whether points lie in the bag's volume (over the back panel, within its seams, past the mouth by a
  depth, not on top of the front panel).
"""

from __future__ import annotations

import numpy as np
import torch

from . import cloth

SEAM_GAP_RADII = 2.2  # the front panel lies this many particle radii above the back one (`cloth.bag`'s)
# front particles within this many spacings of a point (measured along the back panel) count as over or under it:
# above 1/sqrt(2), so a sheet lying flat has one within reach of every point over it
UNDER_REACH = 0.75


def pouch(rows: int = 6, cols: int = 8, spacing: float = cloth.ClothConfig.spacing,
          radius: float = cloth.ClothConfig.radius) -> cloth.ClothLayout:
    """An open bag lying flat (rows along x, the bottom at -x, the mouth at +x; cols along y): back panel at z = 0
    (particles 0 .. rows cols - 1, row-major), front panel `SEAM_GAP_RADII` radii above it (the next rows cols),
    linked particle to particle along both sides (columns 0 and cols - 1) and the bottom (row 0).

    Named: `back`, `front` (each panel's particles, row-major), `back_rim`, `front_rim` (the mouth's rows, along
    +y), `back_bottom` (the back panel's row 0)."""
    mask = np.ones((rows, cols), bool)
    back, back_links, back_border, back_index = cloth._grid(mask, spacing, z=0.0)
    front, front_links, front_border, front_index = cloth._grid(mask, spacing, z=SEAM_GAP_RADII * radius,
                                                                  offset=rows * cols)
    seam = back_index[:, 0].tolist() + back_index[:, -1].tolist() + back_index[0, 1:-1].tolist()
    links = back_links + front_links + [(i, i + rows * cols) for i in seam]
    named = dict(back=back_index.ravel().tolist(), front=front_index.ravel().tolist(),
                 back_rim=back_index[-1].tolist(), front_rim=front_index[-1].tolist(),
                 back_bottom=back_index[0].tolist())
    return cloth.ClothLayout(np.concatenate([back, front]), links, back_border | front_border, named)


def _grid_shape(layout: cloth.ClothLayout) -> tuple[int, int]:
    cols = len(layout.named["back_rim"])
    return len(layout.named["back"]) // cols, cols


def bag_frame(points: torch.Tensor, layout: cloth.ClothLayout) -> dict[str, torch.Tensor]:
    """The back panel's frame now, from particle positions `points` [B, N, 3]: `centre` [B, 3] (its mean), unit
    axes `u` (from the bottom row's mean to the mouth row's), `v` (across, from column 0 to the last, made square
    to `u`), `w` = u x v [B, 3] (the normal towards the front panel: up while the bag lies on its back); `mouth`,
    `bottom` [B] (the mouth row's and bottom row's mean along `u`, from `centre`) and `half_width` [B] (half the
    distance between the first and last columns' means along `v`)."""
    rows, cols = _grid_shape(layout)
    back = points[:, layout.named["back"]].reshape(points.shape[0], rows, cols, 3)
    centre = back.mean(dim=(1, 2))
    bottom, mouth = back[:, 0].mean(dim=1), back[:, -1].mean(dim=1)
    first, last = back[:, :, 0].mean(dim=1), back[:, :, -1].mean(dim=1)
    u = torch.nn.functional.normalize(mouth - bottom, dim=1)
    across = last - first
    v = torch.nn.functional.normalize(across - (across * u).sum(dim=1, keepdim=True) * u, dim=1)
    w = torch.linalg.cross(u, v)
    return dict(centre=centre, u=u, v=v, w=w, mouth=((mouth - centre) * u).sum(dim=1),
                bottom=((bottom - centre) * u).sum(dim=1), half_width=(across * v).sum(dim=1) / 2)


def inside(points: torch.Tensor, layout: cloth.ClothLayout, p: torch.Tensor, spacing: float, min_depth: float,
           max_height: float) -> torch.Tensor:
    """Whether point `p` [B, 3] (a cube's centre) lies in the bag's volume, [B] bool, with the bag's particles at
    `points` [B, N, 3] (`bag_frame`'s axes): along the back panel, between its side columns, between its bottom row
    and `min_depth` (m) short of its mouth row (past the mouth, in the bag); over the back panel: the back-panel
    particles within `UNDER_REACH` spacings of it (along the panel; at least one) all lie below it (along `w`), and
    it lies at most `max_height` (m) above their mean (in the pocket, not held above an open mouth); and not on top
    of the front panel: no front-panel particle within that reach lies below it (the front panel lies over it or,
    where the mouth is held open, nowhere near it). Heights are taken locally, so a back panel bunched or tilted
    elsewhere does not move them. A point on the table beside the bag, under it or on top of the closed bag is not
    inside."""
    f = bag_frame(points, layout)

    def along(q):  # coordinates of q [B, ..., 3] along u, v, w from the centre
        rel = q - f["centre"].view(-1, *([1] * (q.dim() - 2)), 3)
        return [(rel * f[k].view(-1, *([1] * (q.dim() - 2)), 3)).sum(dim=-1) for k in ("u", "v", "w")]

    cu, cv, cw = along(p[:, None])
    cu, cv, cw = cu[:, 0], cv[:, 0], cw[:, 0]
    in_seams = (cu >= f["bottom"]) & (cu <= f["mouth"] - min_depth) & (cv.abs() <= f["half_width"])
    reach = UNDER_REACH * spacing
    bu, bv, bw = along(points[:, layout.named["back"]])
    below = torch.hypot(bu - cu[:, None], bv - cv[:, None]) < reach  # the back particles under (or over) it
    floor = (bw * below).sum(dim=1) / below.sum(dim=1).clamp(min=1)
    in_pocket = below.any(dim=1) & ~(below & (bw >= cw[:, None])).any(dim=1) & (cw - floor <= max_height)
    fu, fv, fw = along(points[:, layout.named["front"]])
    near = torch.hypot(fu - cu[:, None], fv - cv[:, None]) < reach
    under = (near & (fw < cw[:, None])).any(dim=1)
    return in_seams & in_pocket & ~under
