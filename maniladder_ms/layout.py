"""Layout ranges: the catalog params that place a task's objects at reset, their draws and their breadth.

A task's layout ranges are catalog `params` (SI units, angles in degrees), named by one scheme so that a
calibration can read, compare and change them across the ladder (docs/calibration/layout-policy.md):

- `<obj>_x_range`, `<obj>_y_range`: [low, high] in m, the object's centre uniform in it (world frame);
- `<obj>_abs_y_range`: [low, high] in m of |y|, on a random side of the robot's centre line (`sides` 2);
- `<obj>_dx_range`, `<obj>_dy_range`: [low, high] in m, the object's offset from another object (its docstring
  names which), uniform in it;
- `<obj>_yaw_range`: [low, high] in deg, the object's yaw uniform in it; `<obj>_max_yaw`: deg, uniform in
  +- it;
- any other `<quantity>_range` ([low, high], SI units or deg) or `max_<quantity>`: a layout draw the task's
  docstring describes (a distance, a heading, an amplitude).

`uniform` and `uniform_deg` draw from such ranges exactly as the tasks did when the ranges were class
constants (`low + U * (high - low)`, torch's float32 draws); `layout_breadth` reads the catalog and tabulates
each task's position areas, yaw spans and sides (`maniladder show` and the layout policy's table).
"""

from __future__ import annotations

import dataclasses
import re
from typing import Iterable, Sequence

import numpy as np
import torch


def uniform(b: int, low_high: Sequence[float]) -> torch.Tensor:
    """`b` draws uniform in [low, high) (float32, the current torch device)."""
    low, high = low_high
    return low + torch.rand(b) * (high - low)


def uniform_deg(b: int, low_high_deg: Sequence[float]) -> torch.Tensor:
    """`b` angles in radians uniform in the range [low, high) given in degrees."""
    low, high = (float(np.deg2rad(v)) for v in low_high_deg)
    return low + torch.rand(b) * (high - low)


def symmetric_deg(b: int, max_deg: float) -> torch.Tensor:
    """`b` angles in radians uniform in +-`max_deg` degrees (drawn as `(U - 0.5) * 2 * max`)."""
    return (torch.rand(b) - 0.5) * 2 * float(np.deg2rad(max_deg))


# ---- breadth: what a calibration compares across levels -------------------------------------------------

_POS = re.compile(r"^(?P<obj>\w+?)_(?P<axis>x|y|abs_y|dx|dy)_range$")
_YAW_RANGE = re.compile(r"^(?P<obj>\w+?)_yaw_range$")
_MAX_YAW = re.compile(r"^(?P<obj>\w+?)_max_yaw$")


@dataclasses.dataclass(frozen=True)
class ObjectBreadth:
    """One object's layout breadth at reset, from its catalog params."""

    obj: str
    area_cm2: float | None  # the area of its centre's position range (both sides counted), None without x and y
    yaw_deg: float | None  # the width of its yaw range, None when its yaw is not drawn
    sides: int  # 2 when |y| is drawn on a random side, else 1
    relative: bool  # its position is an offset from another object's (`_dx_range` / `_dy_range`)


def object_breadths(params: dict) -> list[ObjectBreadth]:
    """The layout breadth of every object a row's params place, in the params' order."""
    found: dict[str, dict] = {}
    for name, value in params.items():
        m = _POS.match(name)
        if m and _is_range(value):
            found.setdefault(m["obj"], {})[m["axis"]] = value
            continue
        m = _YAW_RANGE.match(name)
        if m and _is_range(value):
            found.setdefault(m["obj"], {})["yaw"] = value[1] - value[0]
            continue
        m = _MAX_YAW.match(name)
        if m and isinstance(value, (int, float)):
            found.setdefault(m["obj"], {})["yaw"] = 2 * value
    out = []
    for obj, axes in found.items():
        x = axes.get("x", axes.get("dx"))
        y = axes.get("y", axes.get("dy", axes.get("abs_y")))
        sides = 2 if "abs_y" in axes else 1
        area = None if x is None or y is None else (x[1] - x[0]) * (y[1] - y[0]) * sides * 1e4
        out.append(ObjectBreadth(obj, None if area is None else round(area, 2), axes.get("yaw"), sides,
                                 "dx" in axes or "dy" in axes))
    return out


def _is_range(value) -> bool:
    return isinstance(value, (list, tuple)) and len(value) == 2 and all(isinstance(v, (int, float)) for v in value)


def layout_breadth(specs: Iterable) -> list[dict]:
    """One row per task spec: level, suite, id, and its objects' breadth (`object_breadths` of its params)."""
    return [dict(level=s.level, suite=s.suite, task=s.id, objects=object_breadths(dict(s.params))) for s in specs]


def format_breadth(objects: Sequence[ObjectBreadth]) -> str:
    """`obj 300 cm2 +-22.5 deg x2` pieces for a table cell or `maniladder show`."""
    parts = []
    for o in objects:
        bits = [o.obj + (" (relative)" if o.relative else "")]
        if o.area_cm2 is not None:
            bits.append(f"{o.area_cm2:g} cm2")
        if o.yaw_deg is not None:
            bits.append(f"yaw {o.yaw_deg:g} deg")
        if o.sides == 2:
            bits.append("2 sides")
        parts.append(" ".join(bits))
    return "; ".join(parts) if parts else "-"
