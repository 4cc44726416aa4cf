"""L1 rigid SX tasks (Panda + LEAP hand): the scripted solvers succeed within the task horizon."""

import pytest

from maniladder_ms.solvers import sweep

SX_TASKS = ["LiftBottleHand", "PressButtonHand", "TurnValveHand"]


@pytest.mark.parametrize("task_id", SX_TASKS)
def test_solver_short_run(task_id):
    rows = sweep(task_id, range(3))
    assert sum(r["success"] for r in rows) >= 2, rows


@pytest.mark.slow
@pytest.mark.parametrize("task_id", SX_TASKS)
def test_solver_success_over_50_seeds(task_id):
    rows = sweep(task_id, range(100, 150))
    failed = [r["seed"] for r in rows if not r["success"]]
    assert sum(r["success"] for r in rows) / len(rows) >= 0.9, f"{task_id}: failed seeds {failed}"
