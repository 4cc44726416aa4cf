"""Every implemented ManiLadder task; importing this registers their env ids without importing the modules.

The tree is by medium: `rigid/`, `articulated/`, `rope/`, `cloth/`, `clay/`, `particles/`. A task is one
module (`rigid/pick_place_pen.py`); a family of several tasks is one package whose `base.py` holds the
unregistered base class with the family's rule and whose other modules are its thin registered variants
(`rigid/handover/`). Task modules import no other task module: what two tasks share lives in their family
base, `maniladder_ms.objects` or `maniladder_ms.solvers`. The decorator
`@register_task("<TaskId>")` stays the one place a task is declared: the module sources are scanned for it
(a text scan, no import), every task found is registered lazily as `ManiLadder-<TaskId>-v1`, and its module
is imported on first use (`gym.make`, `maniladder_ms.make`, `REGISTERED_ENVS[env_id].cls`,
`solvers.solver_for`). So a new task module registers itself without an edit here, `import maniladder_ms`
does not grow with the number of tasks, and a module that fails to import breaks only its own tasks
(`TaskImportError` naming the file).
"""

from __future__ import annotations

import importlib.resources
import re
import warnings

from maniladder_ms.catalog import UnknownTaskError, default_catalog
from maniladder_ms.envs.registration import import_task_module, register_lazy, register_unbuilt

# the decorator at the start of a line with the task id as a string literal
TASK_LINE = re.compile(r"""^@register_task\(\s*["']([A-Za-z0-9_]+)["']""", re.MULTILINE)


def module_files(root=None, prefix: str = "") -> list[str]:
    """Paths, relative to this package and '/'-separated, of every module in the tree (`_*` files skipped)."""
    root = importlib.resources.files(__name__) if root is None else root
    found = []
    for entry in sorted(root.iterdir(), key=lambda e: e.name):
        if entry.is_dir() and not entry.name.startswith(("_", ".")):
            found += module_files(entry, f"{prefix}{entry.name}/")
        elif entry.name.endswith(".py") and not entry.name.startswith("_"):
            found.append(f"{prefix}{entry.name}")
    return found


def scan() -> tuple[dict[str, str], dict[str, list[str]]]:
    """({task id: module file}, {task id: [module files]} of ids declared in more than one module); files are
    relative to this package (`rigid/pick_place_pen.py`)."""
    found: dict[str, list[str]] = {}
    root = importlib.resources.files(__name__)
    for name in module_files():
        for task_id in TASK_LINE.findall(root.joinpath(name).read_text(encoding="utf-8")):
            found.setdefault(task_id, []).append(name)
    return {t: names[0] for t, names in found.items()}, {t: names for t, names in found.items() if len(names) > 1}


FILES, CONFLICTS = scan()


def _module(file_name: str) -> str:
    return f"{__name__}.{file_name[:-3].replace('/', '.')}"


def _path(file_name: str) -> str:
    return f"maniladder_ms/tasks/{file_name}"


def load(task_id: str) -> bool:
    """Import the module of `task_id` (registering its env and solver); False if no module declares it."""
    if task_id not in FILES:
        return False
    import_task_module(task_id, _module(FILES[task_id]), _path(FILES[task_id]), ERRORS.get(task_id))
    return True


def load_all():
    """Import every task module (a `TaskImportError` for the first that fails)."""
    for task_id in FILES:
        load(task_id)


ERRORS = {t: f"declared in several modules: {', '.join(map(_path, names))}" for t, names in CONFLICTS.items()}
for _task_id, _file in FILES.items():
    try:
        register_lazy(_task_id, _module(_file), _path(_file), ERRORS.get(_task_id))
    except UnknownTaskError as e:  # only this task is left out; tests/test_registry.py fails on it
        ERRORS[_task_id] = f"{_path(_file)}: {e}"
        warnings.warn(f"task {_task_id} not registered: {ERRORS[_task_id]}", stacklevel=2)
for _spec in default_catalog():
    if _spec.id not in FILES:  # in the catalog, built by no module yet: gym.make says so
        register_unbuilt(_spec.id)
