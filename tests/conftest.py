"""Shared fixtures, and the task sample CI runs the expensive per-task checks on (docs/building-a-task.md,
"CI budget").

Cheap contract checks (make, reset, step, metadata, no success at reset) run on every implemented task.
Expensive ones (solver run, demo record + verify, rgb obs, state round trip, committed-sample replay) take
their tasks from `sampled_tasks()`: the tasks the branch's changes sample (`changed_tasks`), plus `SAMPLE_SIZE`
tasks that change with the commit (ranked by a hash of `git rev-parse HEAD` and the task id, picked so the first
few cover every embodiment and object class, within a cost budget: demo steps priced by the task's measured speed);
the rest are marked `slow`, so `pytest -m slow` sweeps them all.
`MANILADDER_TEST_TASKS=all` (or a comma-separated list of task ids) overrides the sample.

A change samples a task when it touches the task's own files (its task module, its solver module under
`solvers/`, `demos/<TaskId>/`), or a module in the task's import closure: the maniladder_ms modules that
importing its task and solver modules runs, read statically (`ast`, no import; relative imports resolved, the
packages above each module included). Modules in many closures (envs/base.py, catalog.py, solvers/bimanual.py)
add at most `SHARED_CAP` tasks in all, the narrowest changed module first, each in the commit's hash order.

`fixture_catalog` gives build-state tests made-up unbuilt catalog rows (Level `FIXTURE_LEVEL`), so they hold
whichever real tasks are built.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
from functools import lru_cache
from pathlib import Path

import pytest

import maniladder_ms

REPO = Path(__file__).resolve().parents[1]
SAMPLE_SIZE = 8  # tasks a commit checks expensively, besides the ones it changes
# the sample's cost budget per sampled task, in PickCube-v1 control steps (`check_cost`): a task's expensive checks
# run its episodes (3 solver episodes, 3 demos recorded and replayed, its samples replayed), so they cost about its
# episode length times its time per step, and both vary ~10x over the 84 tasks built (HandoverMugHands: 676 steps at
# 0.22x PickCube-v1's speed, 3073; LiftWideBox: 47 at 0.45x, 104; median 411). A task is sampled while the sample's
# summed cost stays within k x this (the first pick always: any task still comes first for some commit). Over 300
# commits' orders at 84 tasks: mean 5505, worst 7200 (a budget of demo steps alone, 300 a task: 5746 and 9707; the
# landing whose sample cost 8242 took 2423 s in CI, those at 5970-7456 1084-1222 s), 293 samples keep all 8 tasks
SAMPLE_COST_PER_TASK = 900
BENCH_TABLE = REPO / "docs" / "bench" / "state.json"  # `maniladder bench --out`: each task's speed ratio
TASKS_ENV = "MANILADDER_TEST_TASKS"
SHARED_CAP = 4  # tasks a change samples through shared modules it touches, at most (docs: "CI budget")


@pytest.fixture(scope="session")
def catalog():
    return maniladder_ms.default_catalog()


FIXTURE_TASK = "FixtureUnbuiltTask"  # the first made-up row of `fixture_catalog`
FIXTURE_LEVEL = 4  # the level `fixture_catalog` makes of made-up rows only


@pytest.fixture
def fixture_catalog(monkeypatch):
    """The packaged catalog with, for one test, Level `FIXTURE_LEVEL`'s rows replaced by made-up rows that no
    module builds (`FIXTURE_TASK`, then `FixtureUnbuiltTask2`, ...: same suites, counts and numbers), each
    registered as the package registers a catalog row no module declares (`register_unbuilt`). Build-state
    checks ("not implemented yet", "a level / suite with nothing built") run on these rows, whatever the real
    tasks' state: they hold at 56 built tasks and at 112. The rows go into the cached `default_catalog()`
    object, which every module reads (monkeypatched, undone after the test); `get` still finds the real Level
    `FIXTURE_LEVEL` rows by id."""
    import dataclasses

    import gymnasium as gym

    from maniladder_ms.catalog import ENV_ID_FORMAT
    from maniladder_ms.envs.registration import register_unbuilt

    cat = maniladder_ms.default_catalog()
    made_up, rows = iter(range(1, len(cat) + 1)), []
    for spec in cat.tasks:
        if spec.level == FIXTURE_LEVEL:
            k = next(made_up)
            task_id = FIXTURE_TASK if k == 1 else f"{FIXTURE_TASK}{k}"
            spec = dataclasses.replace(spec, id=task_id, env_id=ENV_ID_FORMAT.format(task_id), family=task_id)
        rows.append(spec)
    monkeypatch.setattr(cat, "tasks", tuple(rows))
    # the real rows stay reachable by id (a demo or results file of a real Level 4 task still resolves); only
    # listing and filtering see the made-up level
    monkeypatch.setattr(cat, "_by_id", {**cat._by_id, **{s.id: s for s in rows}})
    made = [s for s in rows if s.level == FIXTURE_LEVEL]
    for spec in made:
        assert spec.env_id not in gym.registry, f"{spec.env_id} is registered already: pick another made-up id"
        register_unbuilt(spec.id)
    assert made[0].id == FIXTURE_TASK and not any(s.implemented for s in made)
    yield cat
    for spec in made:
        gym.registry.pop(spec.env_id, None)


def _git(*args: str) -> str:
    try:
        out = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return ""
    return out.stdout.strip() if out.returncode == 0 else ""


@lru_cache(maxsize=1)
def commit() -> str:
    """The commit the sample is drawn for ("" outside a git checkout: a fixed sample)."""
    return _git("rev-parse", "HEAD")


@lru_cache(maxsize=1)
def task_files() -> dict[str, tuple[frozenset[str], frozenset[str]]]:
    """{implemented task: (its own files, its import closure)}: own = its task module, its solver module (once
    moved to solvers/) and its demos folder prefix; the closure = every maniladder_ms file that importing the two
    modules runs."""
    from maniladder_ms import solvers, tasks
    from maniladder_ms.provenance import import_closure

    implemented = {t.id for t in maniladder_ms.default_catalog().filter(implemented=True)}
    solver_files = solvers.solver_files()
    out = {}
    for task_id, name in tasks.FILES.items():
        if task_id not in implemented:
            continue
        modules = [tasks._module(name)]
        own = {f"maniladder_ms/tasks/{name}", f"demos/{task_id}/"}
        if task_id in solver_files:
            modules.append(solvers.solver_module(task_id))
            own.add(f"maniladder_ms/solvers/{solver_files[task_id]}")
        out[task_id] = (frozenset(own), import_closure(*modules))
    return out


def tasks_for_changes(files, key: str = "", cap: int = SHARED_CAP) -> list[str]:
    """The tasks a change to `files` (repo-relative paths) samples: every task whose own module, solver module
    or demos/<TaskId>/ is among them; then, through the changed files in tasks' import closures, at most `cap`
    more: the narrowest changed module first (fewest importing tasks), each adding the tasks that import it,
    in the order of `_rank(..., key)` (the commit's hash order), until `cap` are added."""
    by_task = task_files()
    files = sorted(set(files))
    own = sorted(t for t, (mine, _) in by_task.items()
                 if any(f in mine or f.startswith(tuple(m for m in mine if m.endswith("/"))) for f in files))
    users = {f: [t for t, (_, closure) in sorted(by_task.items()) if f in closure and t not in own]
             for f in files if f.endswith(".py")}
    added: list[str] = []
    for f in sorted((f for f in users if users[f]), key=lambda f: (len(users[f]), f)):
        added += [t for t in _rank(users[f], key) if t not in added][: cap - len(added)]
    return own + added


@lru_cache(maxsize=1)
def changed_tasks() -> tuple[str, ...]:
    """The tasks the branch's changes sample (`tasks_for_changes` of the files that differ from the merge base
    with main: committed, uncommitted or untracked); none on main itself or outside a checkout."""
    base = next((b for ref in ("main", "origin/main") if (b := _git("merge-base", "HEAD", ref))), "")
    if not base:
        return ()
    files = _git("diff", "--name-only", base).splitlines()
    files += _git("ls-files", "--others", "--exclude-standard", "maniladder_ms", "demos").splitlines()
    return tuple(tasks_for_changes(files, commit()))


def _rank(task_ids, key: str) -> list[str]:
    """`task_ids` in the order of the commit's sample: by a hash of `key` and the id, each next task the
    first in that order to add an embodiment or object class not yet covered (if any does)."""
    cat = maniladder_ms.default_catalog()
    order = sorted(task_ids, key=lambda t: hashlib.sha256(f"{key}:{t}".encode()).hexdigest())
    ranked, embodiments, classes = [], set(), set()
    while order:
        def new(t):
            spec = cat.get(t)
            return (spec.embodiment not in embodiments) + (spec.object_class not in classes)

        pick = max(order, key=new)  # max keeps the first of equals: the hash order breaks ties
        order.remove(pick)
        ranked.append(pick)
        embodiments.add(cat.get(pick).embodiment)
        classes.add(cat.get(pick).object_class)
    return ranked


@lru_cache(maxsize=None)
def demo_steps(task_id: str) -> float:
    """The mean episode length of the task's committed sample demos (its horizon if it has none): the measure of
    its expensive checks' cost the sample budgets."""
    import json

    lengths = [e["elapsed_steps"] for f in sorted((REPO / "demos" / task_id).glob("*.json"))
               for e in json.loads(f.read_text())["episodes"]]
    return sum(lengths) / len(lengths) if lengths else float(maniladder_ms.default_catalog().get(task_id).horizon)


@lru_cache(maxsize=1)
def speed_ratios() -> dict[str, float]:
    """{task id: control steps/s as a ratio to PickCube-v1's} from `BENCH_TABLE` (state, random actions)."""
    import json

    rows = json.loads(BENCH_TABLE.read_text(encoding="utf-8"))["rows"]
    return {spec.id: rows[spec.env_id]["ratio"] for spec in maniladder_ms.default_catalog() if spec.env_id in rows}


@lru_cache(maxsize=None)
def check_cost(task_id: str) -> float:
    """The price of a task's expensive checks in PickCube-v1 control steps: `demo_steps` over its speed ratio
    (`speed_ratios`; a task not in the table is priced at the slowest task's speed, and tests/test_task_sample.py
    asks for its row)."""
    speeds = speed_ratios()
    return demo_steps(task_id) / speeds.get(task_id, min(speeds.values()))


def task_sample(tasks, k: int = SAMPLE_SIZE) -> list[str]:
    """Which of `tasks` the expensive checks run on in this session (see the module docstring): the changed
    tasks, then up to `k` in the commit's order whose summed `check_cost` stays within k x `SAMPLE_COST_PER_TASK`
    (a task that would exceed it is passed over for this commit; over 300 commits' orders 293 samples keep all 8
    slots, 7 end with 7 when slow tasks spent the budget)."""
    tasks = list(tasks)
    chosen = os.environ.get(TASKS_ENV, "").strip()
    if chosen == "all":
        return tasks
    if chosen:
        wanted = {t.strip() for t in chosen.split(",")}
        return [t for t in tasks if t in wanted]
    picked = [t for t in changed_tasks() if t in tasks]
    slots, drawn, spent = 0, [], 0.0  # a changed task in the commit's order takes its slot, as it is checked anyway
    for t in _rank(tasks, commit()):
        if slots == k:
            break
        if t not in picked:
            if drawn and spent + check_cost(t) > k * SAMPLE_COST_PER_TASK:
                continue
            drawn.append(t)
            spent += check_cost(t)
        slots += 1
    return picked + drawn


def sampled_tasks(tasks, k: int = SAMPLE_SIZE) -> list:
    """`tasks` as pytest params: those in `task_sample(tasks, k)` plain, the others marked slow."""
    sample = set(task_sample(tasks, k))
    return [t if t in sample else pytest.param(t, marks=pytest.mark.slow) for t in tasks]


def expected_to_fail(params, reasons: dict) -> list:
    """`params` (task ids, or pytest params of one task id, as `sampled_tasks` gives) with the tasks in `reasons`
    ({task: why}) marked as strictly expected failures: a known shortfall that an issue tracks stays visible, and a
    fix turns it into a test failure that asks to remove the entry (episodes are deterministic per seed)."""
    out = []
    for p in params:
        task, marks = (p, ()) if isinstance(p, str) else (p.values[0], tuple(p.marks))
        if task in reasons:
            p = pytest.param(task, marks=(*marks, pytest.mark.xfail(strict=True, reason=reasons[task])))
        out.append(p)
    return out


def pytest_report_header(config):
    tasks = [t.id for t in maniladder_ms.default_catalog().filter(implemented=True)]
    how = (f"{TASKS_ENV}={os.environ[TASKS_ENV]}" if os.environ.get(TASKS_ENV, "").strip()
           else f"commit {commit()[:12] or '(no git)'}, changed: {', '.join(changed_tasks()) or 'none'}")
    return [f"maniladder task sample ({how}; {TASKS_ENV}=all for every task): "
            f"{', '.join(task_sample(tasks))} (of {len(tasks)} tasks)"]
