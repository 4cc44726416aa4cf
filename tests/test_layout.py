"""Layout ranges are catalog data (maniladder_ms/layout.py, docs/calibration/layout-policy.md): a row's layout
params place the task's objects, no Level 1-2 layout code holds a bare float, every Level 1-2 row names its
ranges by the one scheme, and the layout policy's table is the catalog's."""

import ast
import dataclasses
import inspect
import textwrap
from pathlib import Path

import numpy as np
import pytest
import torch

import maniladder_ms
from maniladder_ms.layout import ObjectBreadth, breadth_tables, layout_breadth, object_breadths

REPO = Path(__file__).resolve().parents[1]
POLICY = REPO / "docs" / "calibration" / "layout-policy.md"



def _low_levels():
    return [t for t in maniladder_ms.default_catalog().filter(implemented=True) if t.level <= 2]


def _centre(points: torch.Tensor) -> list[float]:
    return points.reshape(-1, 3).mean(dim=0)[:2].tolist()


# task, params overridden to one value each, what the reset then puts where (x, y of a point the params place)
FORCED = {
    "PickPlacePen": ({"pen_x_range": [0.05, 0.05], "pen_y_range": [0.1, 0.1]},
                     lambda e: e.pen.pose.p[0, :2].tolist(), [0.05, 0.1]),
    "LiftRopeHand": ({"rope_x_range": [-0.1, -0.1], "rope_y_range": [0.07, 0.07]},
                     lambda e: _centre(torch.stack([link.pose.p[0] for link in e.rope.links])), [-0.1, 0.07]),
    "DragTowelHand": ({"towel_x_range": [-0.08, -0.08], "towel_y_range": [0.03, 0.03]},
                      lambda e: _centre(e.towel.positions()[0]), [-0.08, 0.03]),
    "PourWaterHand": ({"bowl_x_range": [-0.03, -0.03], "bowl_y_range": [0.1, 0.1]},
                      lambda e: e.bowl.pose.p[0, :2].tolist(), [-0.03, 0.1]),
    "HandoverMugHands": ({"coaster_x_range": [-0.1, -0.1], "coaster_y_range": [-0.25, -0.25]},
                         lambda e: e.coaster.pose.p[0, :2].tolist(), [-0.1, -0.25]),
    "Stack6Blocks": ({"block_3_x_range": [0.05, 0.05], "block_3_y_range": [-0.12, -0.12]},
                     lambda e: e.blocks[3].pose.p[0, :2].tolist(), [0.05, -0.12]),
}


@pytest.mark.parametrize("task_id", list(FORCED))
def test_a_rows_layout_params_place_the_objects(task_id, monkeypatch):
    """Narrowing a layout range to one value in the catalog row (the row a calibration edits) puts the object
    there, whatever the seed: the class draws from the row, not from numbers of its own."""
    override, where, expected = FORCED[task_id]
    cat = maniladder_ms.default_catalog()
    spec = cat.get(task_id)
    assert set(override) <= set(spec.params)
    monkeypatch.setitem(cat._by_id, task_id, dataclasses.replace(spec, params={**spec.params, **override}))
    env = maniladder_ms.make(task_id, obs_mode="state")
    try:
        for seed in (0, 1):
            env.reset(seed=seed)
            assert np.allclose(where(env.unwrapped), expected, atol=2e-5), (seed, where(env.unwrapped))
    finally:
        env.close()


def _layout_functions(cls) -> list:
    """`_initialize_episode` of the task class and its task bases, and the task-package methods and functions
    they call (`self.lay_rope(...)`, `lay_between_hands(...)`), recursively; of the helpers, those that draw
    (`torch.rand`, `torch.randint`, `layout.uniform`: geometry helpers such as a rest height are not layout)."""
    found, todo = [], [c.__dict__["_initialize_episode"] for c in cls.__mro__
                       if "_initialize_episode" in c.__dict__ and c.__module__.startswith("maniladder_ms.tasks")]
    while todo:
        fn = inspect.unwrap(todo.pop())
        if fn in found:
            continue
        found.append(fn)
        for node in ast.walk(ast.parse(textwrap.dedent(inspect.getsource(fn)))):
            if not isinstance(node, ast.Call):
                continue
            f = node.func
            if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "self":
                target = inspect.getattr_static(cls, f.attr, None)
            elif isinstance(f, ast.Name):
                target = fn.__globals__.get(f.id)
            else:
                continue
            target = getattr(target, "__func__", target)
            if inspect.isfunction(target) and target.__module__.startswith("maniladder_ms.tasks"):
                todo.append(target)
    return [fn for fn in found if fn.__name__ == "_initialize_episode"
            or any(word in inspect.getsource(fn) for word in ("rand", "uniform"))]


def test_level_1_2_layout_code_holds_no_bare_float():
    """No float literal but the arithmetic of a uniform draw (0, 0.5, 1, 2) in the code that lays a Level 1-2
    task out: ranges are catalog params, fixed geometry a named constant. (Integers are left alone: tensor
    shapes and choices among n, `randint(0, 4)`, would need a type inference to tell from layout numbers.)"""
    from mani_skill.utils.registration import REGISTERED_ENVS

    allowed = {0.0, 0.5, 1.0, 2.0}
    bad = []
    for spec in _low_levels():
        for fn in _layout_functions(REGISTERED_ENVS[spec.env_id].cls):
            source = textwrap.dedent(inspect.getsource(fn))
            for node in ast.walk(ast.parse(source)):
                if isinstance(node, ast.Constant) and isinstance(node.value, float) and node.value not in allowed:
                    bad.append(f"{spec.id}: {fn.__qualname__} ({inspect.getsourcefile(fn)}): {node.value}")
    assert not bad, "\n".join(bad)


def test_the_layout_scan_follows_helpers_and_bases():
    from maniladder_ms.tasks.rope.lift_rope_bimanual import LiftRopeBimanualEnv
    from maniladder_ms.tasks.cloth.lift_towel_hands import LiftTowelHandsEnv

    assert "RopeBetweenArmsTask.lay_rope" in {f.__qualname__ for f in _layout_functions(LiftRopeBimanualEnv)}
    assert "lay_between_hands" in {f.__qualname__ for f in _layout_functions(LiftTowelHandsEnv)}


def test_every_level_1_2_row_names_its_layout_ranges_by_the_scheme():
    """Each Level 1-2 row places at least one object by `<obj>_x_range`-style params;
    every `_range` param is [low, high] with low <= high, every `_max_` param a number >= 0, angles within a turn."""
    missing = []
    for spec in _low_levels():
        if not object_breadths(dict(spec.params)):
            missing.append(spec.id)
        for name, value in spec.params.items():
            if name.endswith("_range"):
                assert len(value) == 2 and value[0] <= value[1], (spec.id, name, value)
            if "_max_" in name and name.split("_max_")[1] in ("x", "y", "dx", "dy", "offset", "yaw"):
                assert value >= 0, (spec.id, name, value)
            if name.endswith("yaw_range"):
                assert value[1] - value[0] <= 360, (spec.id, name, value)
    assert not missing


def test_object_breadths_read_the_naming_scheme():
    params = {"pen_x_range": [-0.12, 0.08], "pen_abs_y_range": [0.06, 0.2], "pen_yaw_range": [0, 180],
              "tray_max_yaw": 45, "tray_x_range": [-0.1, 0.1], "tray_y_range": [0.1, 0.2],
              "cube_max_offset": 0.01, "margin": 0.02, "zone_distance_range": [0.1, 0.15]}
    pen, tray, cube = object_breadths(params)
    assert pen == ObjectBreadth("pen", 20.0, 14.0, 2, 180, False) and pen.area_cm2 == 560
    assert tray.yaw_deg == 90 and tray.area_cm2 == 200 and tray.sides == 1
    assert cube.relative and cube.area_cm2 == 4
    (row,) = layout_breadth([maniladder_ms.default_catalog().get("PickPlacePen")])
    assert row.area_cm2 == 120 and row.yaw_deg == 90 and row.sides == 1  # one side since the layout policy's rule 1


def test_the_layout_policy_shows_the_catalogs_breadth():
    """docs/calibration/layout-policy.md holds `breadth_tables` of today's Level 1-2 rows (regenerate with
    `python -m maniladder_ms.layout` after a layout edit)."""
    assert breadth_tables(_low_levels()) in POLICY.read_text()


def test_a_derived_axis_counts_its_spread_in_the_tables_frame():
    """`layout_derived` (rule 1's derived spreads): a zone whose y is the cube's, an offset whose parent is drawn."""
    params = {"cube_x_range": [0.3, 0.34], "cube_y_range": [-0.05, 0.05], "zone_x_range": [-0.08, -0.02],
              "table_y_range": [1.13, 1.17], "mug_x_range": [-0.5, -0.44], "mug_max_dy": 0.025}
    cube, zone, table, mug = object_breadths(params, {"zone": {"y": ["cube_y_range"]},
                                                      "mug": {"y": ["mug_max_dy", "table_y_range"]}})
    assert zone.area_cm2 == 60 and zone.derived == ("y",) and not zone.relative
    assert mug.y_cm == 9 and mug.area_cm2 == 54 and not mug.relative  # 5 cm of offset over the table's 4 cm
    assert object_breadths(params)[3].relative  # undeclared: an offset, not summed
    (book,) = object_breadths({"book_max_y": 0.1}, {"book": {"x": [0.0144]}})
    assert book.area_cm2 == 28.8  # a width set by geometry, in m


def test_a_bad_layout_derived_term_is_a_catalog_error(tmp_path):
    import yaml

    from maniladder_ms.catalog import CatalogError, load_catalog

    data = yaml.safe_load((REPO / "maniladder_ms" / "data" / "task_catalog.yaml").read_text())
    row = next(r for r in data["tasks"] if r["id"] == "HookCubeWithTool")
    row["layout_derived"] = {"zone": {"y": ["cube_z_range"]}}
    path = tmp_path / "catalog.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(CatalogError, match="cube_z_range.*neither a param of this row"):
        load_catalog(path, instructions=REPO / "maniladder_ms" / "data" / "instructions.yaml")


def test_stack6blocks_slots_count_as_six_objects_and_keep_the_blocks_apart(monkeypatch):
    """Stack6Blocks starts block i in its own slot (`block_<i>_x_range`, `block_<i>_y_range`): the layout counts six
    objects of 4x4 cm, and the class refuses slots that could put two blocks closer than `min_block_spacing`."""
    spec = maniladder_ms.default_catalog().get("Stack6Blocks")
    areas = {o.obj: o.area_cm2 for o in object_breadths(dict(spec.params))}
    assert {f"block_{i}" for i in range(6)} <= set(areas) and sum(areas[f"block_{i}"] for i in range(6)) == 96
    cat = maniladder_ms.default_catalog()
    near = {**spec.params, "block_4_x_range": [-0.06, -0.02]}  # 3 cm from slot 1
    monkeypatch.setitem(cat._by_id, "Stack6Blocks", dataclasses.replace(spec, params=near))
    with pytest.raises(ValueError, match="slots 1 and 4"):
        maniladder_ms.make("Stack6Blocks", obs_mode="state").reset(seed=0)


# Level 2 rows not yet in rule 1's band; a row leaves this list when its layout change lands (the test fails until then)
OUTSIDE_THE_BAND: dict[str, str] = {}


def test_every_level_1_2_layout_lies_in_the_band():
    """Rule 1: every built Level 1-2 task's summed area in 10-120 cm2 (derived spreads counted), widest yaw <= 90 deg."""
    outside = {r.task: (r.area_cm2, r.yaw_deg) for r in layout_breadth(_low_levels())
               if not (10 <= r.area_cm2 <= 120 and r.yaw_deg <= 90)}
    assert set(outside) == set(OUTSIDE_THE_BAND), outside
