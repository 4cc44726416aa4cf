"""Lazy task registration: `import maniladder_ms` registers every task without importing its module; the
module is imported on first use, and a broken one breaks only its own tasks."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest
from mani_skill.utils.registration import REGISTERED_ENVS

import maniladder_ms
from maniladder_ms import tasks
from maniladder_ms.envs.registration import UNSCANNED, LazyEnvSpec
from maniladder_ms.solvers import find_solver

from conftest import FIXTURE_TASK

PACKAGE = Path(maniladder_ms.__file__).resolve().parent


def run_python(code: str, path: Path = PACKAGE.parent) -> str:
    env = {**os.environ, "PYTHONPATH": str(path)}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env,
                            cwd=path)
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def test_import_registers_every_task_without_importing_task_modules():
    out = run_python(
        "import sys, maniladder_ms\n"
        "from mani_skill.utils.registration import REGISTERED_ENVS\n"
        "print(sorted(m for m in sys.modules if m.startswith('maniladder_ms.tasks.')))\n"
        "print(sum(t.env_id in REGISTERED_ENVS for t in maniladder_ms.default_catalog()))\n"
    )
    imported, registered = out.splitlines()
    assert imported == "[]"
    assert int(registered) == len(tasks.FILES)


def test_registry_is_complete_and_every_module_registers_what_the_scan_found():
    assert not tasks.CONFLICTS and not tasks.ERRORS
    catalog = maniladder_ms.default_catalog()
    implemented = {t.id for t in catalog.filter(implemented=True)}
    assert implemented == set(tasks.FILES)
    tasks.load_all()
    assert not UNSCANNED, f"registered by import only (write @register_task('<Id>') at a line start): {UNSCANNED}"
    for task_id, file_name in tasks.FILES.items():
        spec = REGISTERED_ENVS[catalog.get(task_id).env_id]
        assert isinstance(spec, LazyEnvSpec)
        assert spec.cls.__module__ == f"maniladder_ms.tasks.{file_name[:-3].replace('/', '.')}"
        assert gym.spec(spec.uid).kwargs == spec.default_kwargs
        assert find_solver(task_id) is not None, f"{task_id} has no solver"


def test_a_broken_task_module_breaks_only_its_task(tmp_path):
    """A copy of the package with one more task module that raises, for a made-up catalog row added to the
    copy's catalog (so the test does not depend on which real task is unbuilt): the package imports, the
    broken task is listed, making it names the file, and the other tasks still load."""
    import yaml

    copy = tmp_path / "maniladder_ms"
    shutil.copytree(PACKAGE, copy, symlinks=True, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "data" / "agents").unlink()
    (copy / "data" / "agents").symlink_to((PACKAGE / "data" / "agents").resolve())
    catalog_file, instructions_file = copy / "data" / "task_catalog.yaml", copy / "data" / "instructions.yaml"
    data = yaml.safe_load(catalog_file.read_text())
    suites = [row["suite"] for row in data["tasks"]]
    row = next(r for r in data["tasks"] if suites.count(r["suite"]) == 3)  # a suite with room for a 4th task
    data["tasks"].append({**row, "id": FIXTURE_TASK, "env_id": f"ManiLadder-{FIXTURE_TASK}-v1", "family": FIXTURE_TASK})
    catalog_file.write_text(yaml.safe_dump(data, sort_keys=False))
    texts = yaml.safe_load(instructions_file.read_text())
    texts[FIXTURE_TASK] = {"instruction": "Do the made-up fixture task.",
                           "paraphrases": [f"Made-up fixture task, phrasing {k}." for k in range(4)]}
    instructions_file.write_text(yaml.safe_dump(texts, sort_keys=False))
    (copy / "tasks" / "rigid" / "fixture_unbuilt_task.py").write_text(
        'from maniladder_ms.envs import register_task\n\nraise RuntimeError("half-written")\n\n\n'
        f'@register_task("{FIXTURE_TASK}")\nclass FixtureUnbuiltTaskEnv:\n    pass\n'
    )
    out = run_python(
        "import maniladder_ms\n"
        "from maniladder_ms.envs.registration import TaskImportError\n"
        "from mani_skill.utils.registration import REGISTERED_ENVS\n"
        f"print(maniladder_ms.default_catalog().get('{FIXTURE_TASK}').implemented)\n"
        "try:\n"
        f"    maniladder_ms.make('{FIXTURE_TASK}')\n"
        "except TaskImportError as e:\n"
        "    print(e)\n"
        "print(REGISTERED_ENVS['ManiLadder-PickPlacePen-v1'].cls.__name__)\n",
        path=tmp_path,
    )
    listed, error, other = out.splitlines()
    assert listed == "True"
    assert error == ("task FixtureUnbuiltTask: importing maniladder_ms/tasks/rigid/fixture_unbuilt_task.py failed: "
                     "RuntimeError: half-written")
    assert other == "PickPlacePenEnv"


def test_gym_make_of_an_unbuilt_catalog_task_says_not_implemented(fixture_catalog):
    """A catalog task no module builds yet: gym.make names it as not implemented (gymnasium would otherwise
    answer "Did you mean" another task), and it does not count as implemented. Checked on the fixture
    catalog's made-up row (registered as the package registers an unbuilt row) and on every real catalog
    task no module declares (none once all are built)."""
    unbuilt = [s for s in fixture_catalog if not s.implemented]
    assert FIXTURE_TASK in {s.id for s in unbuilt}
    for spec in unbuilt:
        assert spec.env_id in gym.registry and spec.env_id not in REGISTERED_ENVS
        assert spec.id.startswith(FIXTURE_TASK) or spec.id not in tasks.FILES
    with pytest.raises(maniladder_ms.TaskNotImplementedError, match=f"task {FIXTURE_TASK} .*not implemented yet"):
        gym.make(fixture_catalog.get(FIXTURE_TASK).env_id)
