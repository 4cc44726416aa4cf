"""The CI task sample's "changed tasks" (tests/conftest.py): a change samples the tasks whose import closure it
touches, read statically; no env is built and no task module is imported here."""

import sys

import pytest

import conftest
from conftest import SHARED_CAP, TASKS_ENV, task_files, task_sample, tasks_for_changes
from maniladder_ms.provenance import module_imports

BIMANUAL = "maniladder_ms/solvers/bimanual.py"


def importers(path: str) -> list[str]:
    """Tasks whose closure holds `path`."""
    return sorted(t for t, (_, closure) in task_files().items() if path in closure)


def test_closures_are_read_without_importing_task_modules():
    before = {m for m in sys.modules if m.startswith("maniladder_ms.tasks.")}
    task_files.cache_clear()
    closures = task_files()
    assert {m for m in sys.modules if m.startswith("maniladder_ms.tasks.")} == before
    assert len(closures) >= 56
    # absolute, relative and function-level imports, and the packages above each module
    assert "maniladder_ms/solvers/base.py" in module_imports("maniladder_ms/solvers/driven.py")  # `from .base`
    own, closure = closures["HandoverCube"]
    assert own >= {"maniladder_ms/tasks/rigid/handover/handover_cube.py", "demos/HandoverCube/"}
    assert {"maniladder_ms/tasks/rigid/handover/base.py", "maniladder_ms/tasks/rigid/handover/__init__.py",
            "maniladder_ms/tasks/rigid/__init__.py", "maniladder_ms/envs/base.py", BIMANUAL} <= closure
    assert "maniladder_ms/tasks/rigid/pick_place_pen.py" not in closure


def test_a_change_to_a_task_module_or_its_demos_samples_that_task():
    assert tasks_for_changes(["maniladder_ms/tasks/rigid/pick_place_pen.py"]) == ["PickPlacePen"]
    assert tasks_for_changes(["demos/HandoverCube/trajectory.none.pd_ee_delta_pose.physx_cpu.h5"]) == ["HandoverCube"]
    assert tasks_for_changes(["README.md", "docs/building-a-task.md", "tests/test_envs.py"]) == []


def test_a_change_to_a_family_base_samples_its_tasks():
    assert sorted(tasks_for_changes(["maniladder_ms/tasks/rigid/handover/base.py"])) == \
        ["HandoverBallHands", "HandoverCube", "HandoverMugHands", "HandoverPenHands"]


def test_a_change_to_a_shared_solver_module_samples_tasks_that_import_it():
    direct = [t for t, (own, _) in task_files().items()
              if any(BIMANUAL in module_imports(f) for f in own if f.endswith(".py"))]
    users = importers(BIMANUAL)
    assert "HandoverCube" in direct and set(direct) <= set(users) and len(users) > SHARED_CAP
    # uncapped: every task that imports it; capped: SHARED_CAP of them, in the commit's order
    assert sorted(tasks_for_changes([BIMANUAL], cap=len(users))) == users
    picked = tasks_for_changes([BIMANUAL], key="some commit")
    assert len(picked) == SHARED_CAP and set(picked) <= set(users)
    assert picked == tasks_for_changes([BIMANUAL], key="some commit")
    assert picked != tasks_for_changes([BIMANUAL], key="another commit")


def test_a_core_module_samples_a_few_tasks_and_a_changed_task_comes_first():
    assert len(importers("maniladder_ms/envs/base.py")) == len(task_files())
    picked = tasks_for_changes(["maniladder_ms/envs/base.py", "maniladder_ms/tasks/rigid/pick_place_pen.py"], "k")
    assert picked[0] == "PickPlacePen" and len(picked) == 1 + SHARED_CAP and len(set(picked)) == len(picked)
    # the narrower module is served first: a family base next to a core module keeps all its tasks
    picked = tasks_for_changes(["maniladder_ms/envs/base.py", "maniladder_ms/tasks/rigid/handover/base.py"], "k")
    assert sorted(picked[:4]) == ["HandoverBallHands", "HandoverCube", "HandoverMugHands", "HandoverPenHands"]
    assert len(picked) == SHARED_CAP


def test_the_environment_overrides_the_sample(monkeypatch):
    tasks = ["PickPlacePen", "HandoverCube", "Stack6Blocks"]
    monkeypatch.setenv(TASKS_ENV, "all")
    assert task_sample(tasks, 1) == tasks
    monkeypatch.setenv(TASKS_ENV, "Stack6Blocks, PickPlacePen")
    assert task_sample(tasks, 1) == ["PickPlacePen", "Stack6Blocks"]
    monkeypatch.delenv(TASKS_ENV)
    monkeypatch.setattr(conftest, "changed_tasks", lambda: ("HandoverCube",))
    # the changed task first, then the commit's top-ranked one (which may be the changed task itself)
    ranked = conftest._rank(tasks, conftest.commit())[:1]
    assert task_sample(tasks, 1) == ["HandoverCube"] + [t for t in ranked if t != "HandoverCube"]


def test_the_sample_keeps_within_its_cost_budget_and_can_still_draw_any_task(monkeypatch):
    """The commit's sample stops adding slow tasks once its cost (`check_cost`: demo steps over the task's speed)
    would pass k x SAMPLE_COST_PER_TASK, and the costliest task is still checked by a commit whose order puts it
    first."""
    import hashlib

    tasks = sorted(task_files())
    monkeypatch.setattr(conftest, "changed_tasks", lambda: ())
    budget = 8 * conftest.SAMPLE_COST_PER_TASK
    for i in range(40):
        monkeypatch.setattr(conftest, "commit", lambda i=i: f"key{i}")
        sample = task_sample(tasks, 8)
        assert 6 <= len(sample) <= 8 and len(set(sample)) == len(sample)  # fewer when slow tasks spent the budget
        assert sample[0] == conftest._rank(tasks, f"key{i}")[0]  # the commit's first pick is never passed over
        assert sum(map(conftest.check_cost, sample)) <= budget
    costliest = max(tasks, key=conftest.check_cost)
    assert conftest.check_cost(costliest) > 3 * conftest.SAMPLE_COST_PER_TASK  # the budget has something to cap
    first = next(f"k{i}" for i in range(100000)
                 if min(tasks, key=lambda t, i=i: hashlib.sha256(f"k{i}:{t}".encode()).hexdigest()) == costliest)
    monkeypatch.setattr(conftest, "commit", lambda: first)
    assert task_sample(tasks, 8)[0] == costliest


def test_every_built_task_has_a_speed_row():
    """The sample prices each task by its measured speed: a new task's bench row goes into the table
    (`maniladder bench TASK --out docs/bench/state.json --update`)."""
    missing = sorted(set(task_files()) - set(conftest.speed_ratios()))
    assert not missing, f"no row in {conftest.BENCH_TABLE.relative_to(conftest.REPO)}: {missing}"
