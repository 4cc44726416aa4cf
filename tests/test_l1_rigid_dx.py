"""L1-rigid-DX tasks (two Panda arms with LEAP hands): the scripted solvers succeed within the horizon."""

import pytest

from maniladder_ms.solvers import sweep

TASKS = ["LiftBasketHands", "OpenDoubleDoorsHands"]


def successes(task_id, seeds):
    return sum(row["success"] for row in sweep(task_id, seeds))


@pytest.mark.parametrize("task_id", TASKS)
def test_solver_short(task_id):
    assert successes(task_id, range(3)) >= 2


@pytest.mark.slow
@pytest.mark.parametrize("task_id", TASKS)
def test_solver_50_seeds(task_id):
    assert successes(task_id, range(100, 150)) >= 45
