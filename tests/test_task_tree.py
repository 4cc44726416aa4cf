"""The task tree's promises, read statically (no env is built): every task's solver lives in the solver tree at
its task's path, no task module registers a solver, and no task module imports another task's module (a task
imports at most its family's `base.py` and its medium's `base.py`), so a broken module breaks only its own
tasks and what two tasks share has one home."""

from pathlib import Path

from maniladder_ms import solvers, tasks

from conftest import REPO
from maniladder_ms.provenance import module_imports

TASKS = "maniladder_ms/tasks/"


def test_every_solver_sits_in_the_solver_tree_at_its_task_s_path():
    files = solvers.solver_files()
    assert set(files) == set(tasks.FILES)
    moved = {t: f for t, f in files.items() if f != tasks.FILES[t]}
    assert not moved, f"solver modules not at their task's path under maniladder_ms/solvers/: {moved}"


def test_no_task_module_registers_a_solver():
    for name in tasks.module_files():
        text = (REPO / TASKS / name).read_text(encoding="utf-8")
        assert "register_solver" not in text, f"{TASKS}{name} registers a solver: it belongs in the solver tree"


def allowed_task_imports(name: str) -> set[str]:
    """The task-tree files a task module `name` (relative to tasks/) may import: the packages above it, its
    own family's base.py and its medium's base.py."""
    parts = Path(name).parts
    allowed = {f"{TASKS}__init__.py"}
    for k in range(1, len(parts)):
        folder = "/".join(parts[:k])
        allowed |= {f"{TASKS}{folder}/__init__.py", f"{TASKS}{folder}/base.py"}
    return allowed


def test_no_task_module_imports_another_task_module():
    found = []
    for name in tasks.module_files():
        own = f"{TASKS}{name}"
        imported = {f for f in module_imports(own) if f.startswith(TASKS)} - {own}
        found += [f"{own} imports {f}" for f in sorted(imported - allowed_task_imports(name))]
    assert not found, "\n".join(found)


def test_the_import_check_can_fail():
    """A module importing a sibling task is caught (the rule above is not vacuous)."""
    sibling = f"{TASKS}rigid/pick_place_pen.py"
    assert sibling not in allowed_task_imports("rigid/hang_mug.py")
    assert f"{TASKS}rigid/handover/base.py" in allowed_task_imports("rigid/handover/handover_cube.py")
    assert f"{TASKS}rigid/handover/base.py" not in allowed_task_imports("rigid/hang_mug.py")


def test_no_task_module_imports_the_solvers():
    """An env runs without its solver (a user's policy drives it): task modules import nothing from solvers/."""
    found = [f"{TASKS}{name} imports {f}" for name in tasks.module_files()
             for f in sorted(module_imports(f"{TASKS}{name}")) if f.startswith("maniladder_ms/solvers/")]
    assert not found, "\n".join(found)
