"""L1 rigid SG tasks beyond the PickPlacePen example: short solver runs here, 50-seed sweeps behind `slow`."""

import pytest

from maniladder_ms.solvers import sweep

SG_TASKS = ["HangMug", "OpenBoxRetrieval", "PivotBook"]


@pytest.mark.parametrize("task_id", SG_TASKS)
def test_solver_short_run(task_id):
    rows = sweep(task_id, range(3))
    assert sum(r["success"] for r in rows) >= 2, rows


@pytest.mark.slow
@pytest.mark.parametrize("task_id", SG_TASKS)
def test_solver_success_over_50_seeds(task_id):
    rows = sweep(task_id, range(100, 150))
    rate = sum(r["success"] for r in rows) / len(rows)
    assert rate >= 0.9, f"{task_id}: {rate:.0%}; failed seeds {[r['seed'] for r in rows if not r['success']]}"
