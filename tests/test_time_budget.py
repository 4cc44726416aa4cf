"""The time budget (docs/calibration/time-budget.md): every built Level 1-2 task's horizon lies in 1.25-2.5x the mean
length of its 20 demos, read from the README's solver table, whose horizon column is the catalog's."""

from pathlib import Path

import maniladder_ms

REPO = Path(__file__).resolve().parent.parent
LOW, HIGH = 1.25, 2.5
HEADER = "| task | suite | solver success (100-149) | held-out 150-199 | mean steps | horizon | swept |"


def solver_table() -> dict[str, tuple[str, str, int]]:
    """{task: (suite, demo mean as written, horizon)} from the README's solver table."""
    lines = (REPO / "README.md").read_text(encoding="utf-8").splitlines()
    start = lines.index(HEADER)
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith("| "):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        rows[cells[0]] = (cells[1], cells[4], int(cells[5]))
    return rows


def test_every_built_level_1_2_task_has_a_row_with_the_catalogs_horizon():
    rows = solver_table()
    catalog = maniladder_ms.default_catalog()
    built = [s for s in catalog if s.implemented and s.level in (1, 2)]
    assert len(built) == 56
    missing = [s.id for s in built if s.id not in rows]
    assert not missing, f"no README solver row: {missing}"
    wrong = {s.id: (rows[s.id][2], s.horizon) for s in built if rows[s.id][2] != s.horizon}
    assert not wrong, f"README horizon vs catalog horizon: {wrong}"


def test_level_1_2_horizons_lie_in_the_time_budget():
    catalog = maniladder_ms.default_catalog()
    outside = {}
    for task, (suite, mean, horizon) in solver_table().items():
        if catalog.get(task).level not in (1, 2):
            continue
        ratio = horizon / float(mean.lstrip("~"))
        if not LOW <= ratio <= HIGH:
            outside[task] = round(ratio, 2)
    assert not outside, f"horizon / demo mean outside [{LOW}, {HIGH}]: {outside} (docs/calibration/time-budget.md)"

