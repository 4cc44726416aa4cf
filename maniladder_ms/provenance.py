"""What a measured number was measured on: the task's version (`task_hash`) and the machine's (`environment`).

- `task_hash(task_id)`: a hash of everything that decides how the task plays out and what its solver records:
  the catalog row (params, rule text, horizon, level), the source of every maniladder_ms module that importing
  the task's module and its solver's module runs (read statically, `import_closure`: the family base, the
  medium's base, objects, agents, the env base...), the robot assets and the shipped collision decompositions.
  A calibration work folder is keyed by it, so a changed task recomputes its stages instead of reusing demos
  and checkpoints of an older version.
- `environment()`: commit, package versions, torch threads, python; the renderer and device are added by the
  caller that chose them.
"""

from __future__ import annotations

import ast
import hashlib
import json
import platform
import subprocess
from functools import lru_cache
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
ROOT = PACKAGE.parent  # the checkout, or site-packages for a wheel install
# data every task reads besides its modules: robot descriptions and meshes, convex decompositions
TASK_DATA_DIRS = ("data/agents", "data/convex")
# the catalog fields that change how a task plays out or is judged (not its scores, description or instructions)
PLAYED_FIELDS = ("id", "env_id", "family", "level", "embodiment", "mobile", "params", "success", "success_template",
                 "horizon")


@lru_cache(maxsize=None)
def _module_file(dotted: str) -> str | None:
    """The root-relative file of a maniladder_ms module or package (`a/b.py` or `a/b/__init__.py`), if any."""
    parts = dotted.split(".")
    if parts[0] != "maniladder_ms" or not all(p.isidentifier() for p in parts):
        return None
    base = ROOT.joinpath(*parts)
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path.relative_to(ROOT).as_posix()
    return None


@lru_cache(maxsize=None)
def _with_packages(dotted: str) -> frozenset[str]:
    """The files Python runs to import `dotted`: the module's and every package's above it."""
    parts = dotted.split(".")
    return frozenset(f for k in range(1, len(parts) + 1) if (f := _module_file(".".join(parts[:k]))))


@lru_cache(maxsize=None)
def module_imports(path: str) -> frozenset[str]:
    """The maniladder_ms files that the module file `path` (root-relative) imports, read statically (`ast`, no
    import): `import a.b`, `from a.b import c` (c a submodule or a name), relative imports resolved, imports
    inside functions included, each with the packages above it. A file that does not parse imports nothing."""
    try:
        tree = ast.parse((ROOT / path).read_text(encoding="utf-8"))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return frozenset()
    package = path[:-3].replace("/", ".").removesuffix(".__init__")
    if not path.endswith("/__init__.py"):
        package = package.rpartition(".")[0]
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                module = ".".join(up + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            names += [module, *(f"{module}.{a.name}" for a in node.names if a.name != "*")]
    return frozenset(f for name in names for f in _with_packages(name))


def import_closure(*dotted: str) -> frozenset[str]:
    """Every maniladder_ms file that importing the modules `dotted` runs, transitively (static, see
    `module_imports`)."""
    todo = [f for d in dotted for f in _with_packages(d)]
    seen = set(todo)
    while todo:
        for f in module_imports(todo.pop()):
            if f not in seen:
                seen.add(f)
                todo.append(f)
    return frozenset(seen)


def task_modules(task_id: str) -> list[str]:
    """The dotted modules of a built task: its task module and, if it has one, its solver's."""
    from maniladder_ms import solvers, tasks

    if task_id not in tasks.FILES:
        raise KeyError(f"{task_id} has no task module (not built)")
    modules = [tasks._module(tasks.FILES[task_id])]
    if task_id in solvers.solver_files():
        modules.append(solvers.solver_module(task_id))
    return modules


def task_source_files(task_id: str) -> list[str]:
    """The root-relative module files a task's version depends on (`import_closure` of `task_modules`)."""
    return sorted(import_closure(*task_modules(task_id)))


def tree_digest(rel: str = "", suffixes: tuple[str, ...] | None = None) -> str:
    """sha256 over the files under the package folder `rel` (each file's relative path and bytes, in sorted
    order), only those ending in `suffixes` if given; bytecode caches left out."""
    h = hashlib.sha256()
    base = PACKAGE / rel
    files = sorted(p for p in base.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                   and (suffixes is None or p.suffix in suffixes)) if base.exists() else ()
    for f in files:
        h.update(f.relative_to(PACKAGE).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


@lru_cache(maxsize=None)
def task_hash_parts(task_id: str) -> dict:
    """{part: digest} behind `task_hash`: the catalog row, each source file, each data folder."""
    from maniladder_ms.catalog import default_catalog

    spec = default_catalog().get(task_id)
    row = {k: getattr(spec, k) for k in PLAYED_FIELDS}
    parts = {"catalog_row": hashlib.sha256(json.dumps(row, sort_keys=True, default=str).encode()).hexdigest()}
    for f in task_source_files(task_id):
        parts[f] = hashlib.sha256((ROOT / f).read_bytes()).hexdigest()
    for d in TASK_DATA_DIRS:
        parts[d] = tree_digest(d)
    return parts


def task_hash(task_id: str) -> str:
    """The version of a task as 16 hex digits: equal hashes, the same task (see the module doc)."""
    return hashlib.sha256(json.dumps(task_hash_parts(task_id), sort_keys=True).encode()).hexdigest()[:16]


@lru_cache(maxsize=1)
def git_commit() -> str:
    """The checkout's commit (with `+dirty` for uncommitted changes to tracked files); "" outside a checkout."""
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
        if head.returncode != 0:
            return ""
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=30)
        return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.TimeoutExpired):
        return ""


def package_versions() -> dict:
    from importlib import metadata

    out = {}
    for name in ("maniladder-ms", "mani-skill", "sapien", "torch", "numpy", "gymnasium"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def environment(**extra) -> dict:
    """Commit, package versions, torch threads, python and machine, plus `extra` (renderer, device, ...)."""
    import torch

    return {"commit": git_commit(), "packages": package_versions(), "torch_threads": torch.get_num_threads(),
            "python": platform.python_version(), "machine": platform.machine(), **extra}
