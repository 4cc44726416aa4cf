"""The scripted solvers of the example tasks reach the success rule within the task's horizon."""

import pytest

from maniladder_ms.solvers import sweep

EXAMPLES = ["PickPlacePen", "Stack6Blocks"]


@pytest.mark.parametrize("task_id", EXAMPLES)
def test_solver_success_over_20_seeds(task_id):
    rows = sweep(task_id, range(20))
    rate = sum(r["success"] for r in rows) / len(rows)
    failed = [r["seed"] for r in rows if not r["success"]]
    assert rate >= 0.9, f"{task_id} solver success {rate:.0%} over 20 seeds; failed seeds {failed}"


# CI runs the PickPlacePen sweep as its sample of the slow tests
@pytest.mark.slow
@pytest.mark.parametrize("task_id", [pytest.param("PickPlacePen", marks=pytest.mark.sample), "Stack6Blocks"])
def test_solver_success_over_50_seeds(task_id):
    rows = sweep(task_id, range(100, 150))
    assert sum(r["success"] for r in rows) / len(rows) >= 0.9
