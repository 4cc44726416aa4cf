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

from conftest import sampled_tasks

TASKS = [t.id for t in maniladder_ms.default_catalog().filter(implemented=True)]
SHORT_SEEDS = range(100, 103)
SWEEP_SEEDS = range(100, 150)


def failed_seeds(rows):
    return [r["seed"] for r in rows if not r["success"]]


# built tasks whose solver is still below the 90 % bar (issues 39 / 40 track them): {task: (what was measured, the
# tests expected to fail)}. Episodes are deterministic per seed, so the failures are strict: a solver that reaches the
# bar turns the expected failure into a test failure that asks to remove the entry
BELOW_BAR = {
    "PickThinCardHand": ("40/50 over seeds 100-149 (docs/tasks/PickThinCardHand.md)", ("sweep",)),
    "FillCupToLine": ("44/50 over seeds 100-149; seeds 100 and 102 overfill (docs/tasks/FillCupToLine.md)",
                      ("short", "sweep")),
}


def below_bar(params, test: str) -> list:
    """`params` (task ids, or pytest params of one task id) with the BELOW_BAR tasks of `test` marked strict xfail."""
    out = []
    for p in params:
        task, marks = (p, ()) if isinstance(p, str) else (p.values[0], tuple(p.marks))
        if task in BELOW_BAR and test in BELOW_BAR[task][1]:
            xfail = pytest.mark.xfail(strict=True, reason=f"solver below the bar: {BELOW_BAR[task][0]}")
            p = pytest.param(task, marks=(*marks, xfail))
        out.append(p)
    return out


@pytest.mark.parametrize("task_id", below_bar(sampled_tasks(TASKS), "short"))
def test_solver_short_run(task_id):
    rows = sweep(task_id, SHORT_SEEDS)
    assert [r["seed"] for r in rows] == list(SHORT_SEEDS)
    assert len(failed_seeds(rows)) <= 1, f"{task_id}: failed seeds {failed_seeds(rows)} of {list(SHORT_SEEDS)}; {rows}"


@pytest.mark.slow
@pytest.mark.parametrize("task_id", below_bar(TASKS, "sweep"))
def test_solver_success_over_50_seeds(task_id):
    rows = sweep(task_id, SWEEP_SEEDS)
    rate = 1 - len(failed_seeds(rows)) / len(rows)
    assert rate >= 0.9, f"{task_id}: {rate:.0%}; failed seeds {failed_seeds(rows)}"
