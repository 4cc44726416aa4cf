"""Every built task's scripted solver reaches the success rule within the task's horizon, at every level: a
3-seed run (seeds 100-102, at most one failure) and the 50-seed sweep (seeds 100-149) that the issues' 90% bar
is measured on. Tasks join as soon as their env is registered. CI runs the 3-seed run on the commit's task
sample (tests/conftest.py `sampled_tasks`; the other tasks' runs are marked `slow`); the 50-seed sweep is
`slow` for every task (`pytest -m slow tests/test_task_solvers.py`).

`solvers.sweep` counts an episode as a success only if it succeeds within the horizon. PickPlacePen, the
example task, also has its own 20-seed check in test_solvers.py.
"""

import pytest

import maniladder_ms
from maniladder_ms.solvers import sweep

from conftest import expected_to_fail, sampled_tasks

TASKS = [t.id for t in maniladder_ms.default_catalog().filter(implemented=True)]
SHORT_SEEDS = range(100, 103)
SWEEP_SEEDS = range(100, 150)


def failed_seeds(rows):
    return [r["seed"] for r in rows if not r["success"]]


# built tasks whose solver is still below the 90 % bar (issues 39 / 40 track them; `expected_to_fail`)
BELOW_BAR_SWEEP = {
    "RouteCableClipsHand": "solver below the bar: 32/50 over seeds 100-149 (1e1d4b4; ac8c3ae gains 110 and 126 "
                           "on the 22 seeds re-run), capsules left on the clip walls' top, blocked pinches and clips "
                           "emptied while the next is done (docs/tasks/RouteCableClipsHand.md)",
}
BELOW_BAR_SHORT: dict[str, str] = {}


@pytest.mark.parametrize("task_id", expected_to_fail(sampled_tasks(TASKS), BELOW_BAR_SHORT))
def test_solver_short_run(task_id):
    rows = sweep(task_id, SHORT_SEEDS)
    assert [r["seed"] for r in rows] == list(SHORT_SEEDS)
    assert len(failed_seeds(rows)) <= 1, f"{task_id}: failed seeds {failed_seeds(rows)} of {list(SHORT_SEEDS)}; {rows}"


@pytest.mark.slow
@pytest.mark.parametrize("task_id", expected_to_fail(TASKS, BELOW_BAR_SWEEP))
def test_solver_success_over_50_seeds(task_id):
    rows = sweep(task_id, SWEEP_SEEDS)
    rate = 1 - len(failed_seeds(rows)) / len(rows)
    assert rate >= 0.9, f"{task_id}: {rate:.0%}; failed seeds {failed_seeds(rows)}"
