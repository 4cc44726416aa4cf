"""Layout ranges: the catalog params that place a task's objects at reset, their draws and their breadth.

A task's layout ranges are catalog `params` (SI units, angles in degrees), named by one scheme so that a
calibration can read, compare and change them across the ladder (docs/calibration/layout-policy.md):

- `<obj>_x_range`, `<obj>_y_range`: [low, high] in m, the object's centre uniform in it (table frame);
- `<obj>_abs_y_range`: [low, high] in m of |y|, on a random side of the robot's centre line (`sides` 2);
- `<obj>_dx_range`, `<obj>_dy_range`: [low, high] in m, the object's offset from another object (its docstring
  names which), uniform in it;
- `<obj>_max_x`, `<obj>_max_y` (m): the centre uniform in +- it (`<obj>_max_dx`, `<obj>_max_dy`: an offset
  from another object); `<obj>_max_offset` (m): an offset from another object uniform in +- it along both axes;
- `<obj>_yaw_range`: [low, high] in deg, the object's yaw uniform in it; `<obj>_max_yaw`: deg, uniform in
  +- it;
- any other `<quantity>_range` ([low, high], SI units or deg) or `<obj>_max_<quantity>`: a layout draw the
  task's docstring describes (a distance, a gap, a bearing, a rope's S amplitude, a scale factor).

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

_POS_RANGE = re.compile(r"^(?P<obj>\w+?)_(?P<axis>x|y|abs_y|dx|dy)_range$")
_POS_MAX = re.compile(r"^(?P<obj>\w+?)_max_(?P<axis>x|y|dx|dy|offset)$")
_YAW_RANGE = re.compile(r"^(?P<obj>\w+?)_yaw_range$")
_MAX_YAW = re.compile(r"^(?P<obj>\w+?)_max_yaw$")


@dataclasses.dataclass(frozen=True)
class ObjectBreadth:
    """One object's layout breadth at reset, read from its catalog params by the naming scheme above."""

    obj: str
    x_cm: float | None  # the width of its centre's x range (cm), None when x is not drawn
    y_cm: float | None  # the width of its y range (cm; one side's for `_abs_y_range`)
    sides: int  # 2 when |y| is drawn on a random side, else 1
    yaw_deg: float | None  # the width of its yaw range (deg), None when its yaw is not drawn
    relative: bool  # its position is an offset from another object's
    derived: tuple[str, ...] = ()  # the axes whose width the row's `layout_derived` gives (in the table's frame)

    @property
    def area_cm2(self) -> float | None:
        """The area its centre can land in (cm^2; both sides counted), None unless both x and y are drawn."""
        if self.x_cm is None or self.y_cm is None:
            return None
        return round(self.x_cm * self.y_cm * self.sides, 2)


def object_breadths(params: dict, derived: dict | None = None) -> list[ObjectBreadth]:
    """The layout breadth of every object a row's params place, in the params' order. `derived` (the row's
    `layout_derived`) gives an object's axis whose spread follows from other draws (docs/calibration/layout-policy.md,
    rule 1): that axis's width in the table's frame is the sum of its terms' widths, and the object counts in the
    table's frame (an offset's parent spread is then in its terms)."""
    found: dict[str, dict] = {}
    for name, value in params.items():
        for pattern, kind in ((_POS_RANGE, "range"), (_POS_MAX, "max"), (_YAW_RANGE, "yaw_range"), (_MAX_YAW, "max_yaw")):
            m = pattern.match(name)
            if m is None or not (_is_range(value) if kind.endswith("range") else _is_number(value)):
                continue
            axes = found.setdefault(m["obj"], {})
            width = _width(value)
            if kind in ("yaw_range", "max_yaw"):
                axes["yaw"] = width
            elif m["axis"] == "offset":
                axes.update(dx=width, dy=width)
            else:
                axes[m["axis"]] = width
            break
    derived = derived or {}
    for obj in derived:
        found.setdefault(obj, {})
    out = []
    for obj, axes in found.items():
        x = axes.get("x", axes.get("dx"))
        y = next((axes[k] for k in ("y", "abs_y", "dy") if k in axes), None)
        given = derived.get(obj, {})
        if "x" in given:
            x = sum(_term_width(params, t) for t in given["x"])
        if "y" in given:
            y = sum(_term_width(params, t) for t in given["y"])
        out.append(ObjectBreadth(obj, _cm(x), _cm(y), 2 if "abs_y" in axes else 1, axes.get("yaw"),
                                 ("dx" in axes or "dy" in axes) and not given, tuple(sorted(given))))
    return out


def _width(value) -> float:
    """A param's spread: a [low, high] range's high - low, a `max_` number's 2 x value (drawn in +-value)."""
    return value[1] - value[0] if _is_range(value) else 2 * value


def _term_width(params: dict, term) -> float:
    """A `layout_derived` term's width (m): a range or `max_` param's `_width`, a number itself."""
    if not isinstance(term, str):
        return float(term)
    value = params[term]
    if _is_range(value) or (_is_number(value) and "max_" in term):
        return _width(value)
    raise ValueError(f"layout_derived term {term!r} = {value!r}: expected a [low, high] range or a max_ param")


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _is_range(value) -> bool:
    return isinstance(value, (list, tuple)) and len(value) == 2 and all(_is_number(v) for v in value)


def _cm(width_m: float | None) -> float | None:
    return None if width_m is None else round(100 * width_m, 3)


def format_breadth(objects: Sequence[ObjectBreadth]) -> str:
    """`pen 20x14 cm x2 sides = 560 cm2, yaw 180 deg; ...`: a table cell or `maniladder show`'s layout line."""
    parts = []
    for o in objects:
        bits = [o.obj + (" (offset)" if o.relative else "")]
        if o.x_cm is not None or o.y_cm is not None:
            size = f"{_g(o.x_cm) if o.x_cm is not None else '-'}x{_g(o.y_cm) if o.y_cm is not None else '-'} cm"
            if o.sides == 2:
                size += " x2 sides"
            if o.derived:
                size += f" ({' and '.join(o.derived)} derived)"
            if o.area_cm2 is not None:
                size += f" = {_g(o.area_cm2)} cm2"
            bits.append(size)
        if o.yaw_deg is not None:
            bits.append(f"yaw {_g(o.yaw_deg)} deg")
        parts.append(" ".join(bits[:1]) + (" " + ", ".join(bits[1:]) if len(bits) > 1 else ""))
    return "; ".join(parts) if parts else "-"


def _g(x: float) -> str:
    return f"{x:.4g}"


@dataclasses.dataclass(frozen=True)
class TaskBreadth:
    """A task's layout breadth: its objects', and two summaries a level's band is read on."""

    level: int
    suite: str
    task: str
    objects: tuple[ObjectBreadth, ...]

    @property
    def area_cm2(self) -> float:
        """The summed area (cm^2) of the objects placed in the table's frame (offsets from another object left out)."""
        return round(sum(o.area_cm2 or 0.0 for o in self.objects if not o.relative), 2)

    @property
    def yaw_deg(self) -> float:
        """The widest yaw range (deg) of its objects, 0 when no yaw is drawn."""
        return max((o.yaw_deg or 0.0 for o in self.objects), default=0.0)

    @property
    def sides(self) -> int:
        return max((o.sides for o in self.objects), default=1)


def layout_breadth(specs: Iterable) -> list[TaskBreadth]:
    """One `TaskBreadth` per catalog task spec, in the order given."""
    return [TaskBreadth(s.level, s.suite, s.id, tuple(object_breadths(dict(s.params), s.layout_derived)))
            for s in specs]


def breadth_tables(specs: Iterable) -> str:
    """Markdown: the per-task table (level, suite, task, summed area, widest yaw, sides, each object) and a
    per-level-and-suite summary (median and range of the tasks' areas and widest yaws; a task whose row holds no
    layout params is listed, not counted). The layout policy's tables are this function's output over the
    catalog's Level 1 and 2 tasks."""
    rows = layout_breadth(specs)
    lines = ["| level | suite | task | area cm2 | widest yaw deg | sides | objects |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        if r.objects:
            lines.append(f"| {r.level} | {r.suite} | {r.task} | {_g(r.area_cm2)} | {_g(r.yaw_deg)} | {r.sides} | "
                         f"{format_breadth(r.objects)} |")
        else:
            lines.append(f"| {r.level} | {r.suite} | {r.task} | - | - | - | no layout params in its row |")
    lines += ["", "| level | suite | tasks counted | area cm2: median (min-max) | widest yaw deg: median (min-max) |",
              "|---|---|---|---|---|"]
    groups: dict[tuple, list[TaskBreadth]] = {}
    for r in rows:
        if r.objects:
            groups.setdefault((r.level, r.suite), []).append(r)
            groups.setdefault((r.level, "all"), []).append(r)
    for (level, suite), group in groups.items():
        if suite != "all":
            continue
        for (lv, su), members in [*((k, v) for k, v in groups.items() if k[0] == level and k[1] != "all"),
                                  ((level, "all"), group)]:
            areas, yaws = [g.area_cm2 for g in members], [g.yaw_deg for g in members]
            lines.append(f"| {lv} | {su} | {len(members)} | {_g(float(np.median(areas)))} ({_g(min(areas))}-"
                         f"{_g(max(areas))}) | {_g(float(np.median(yaws)))} ({_g(min(yaws))}-{_g(max(yaws))}) |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # the layout policy's tables: python -m maniladder_ms.layout
    from maniladder_ms.catalog import default_catalog

    print(breadth_tables(t for t in default_catalog().filter(implemented=True) if t.level <= 2), end="")
