"""CoACD convex decompositions of procedural meshes: shipped with the package, or computed once and cached.

Keyed by the mesh itself and the decomposition settings, so any change to either recomputes. CoACD gives
different parts from run to run even with a fixed seed, so the decompositions the tasks use ship as package
data (`maniladder_ms/data/convex/<kind>_<key>/`, looked up first): every install then simulates the same
collision shapes and the committed demos replay. Any other mesh is decomposed on first use into the user
cache (`maniladder_ms.paths.cache_dir`); to ship a new one, copy that folder (the one the task's demos were
recorded with) into `maniladder_ms/data/convex/` (tests/test_demos.py::test_task_decompositions_are_shipped
names it).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import trimesh

from maniladder_ms.paths import PACKAGE_DIR, cache_dir

SHIPPED_DIR = PACKAGE_DIR / "data" / "convex"


def mesh_key(mesh: trimesh.Trimesh, settings: list) -> str:
    """Cache key of a mesh and the settings it is processed with."""
    digest = hashlib.sha1(np.round(mesh.vertices, 6).tobytes() + mesh.faces.tobytes())
    digest.update(json.dumps(settings).encode())
    return digest.hexdigest()[:16]


def _entry(path: Path) -> tuple[Path, list[Path]] | None:
    """(visual, parts) of a complete decomposition folder, else None."""
    visual = path / "visual.obj"
    parts = sorted(path.glob("part_*.obj"))
    return (visual, parts) if visual.exists() and parts else None


def decompose(mesh: trimesh.Trimesh, threshold: float, max_hulls: int, path: Path) -> tuple[Path, list[Path]]:
    """Run CoACD on `mesh` and write its parts and visual into the folder `path`."""
    import coacd

    coacd.set_log_level("error")
    hulls = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=threshold, max_convex_hull=max_hulls,
                            preprocess_mode="off", seed=0)
    parts = []
    for k, (v, f) in enumerate(hulls):
        part = path / f"part_{k:02d}.obj"
        trimesh.Trimesh(v, f).export(part)
        parts.append(part)
    visual = path / "visual.obj"
    mesh.export(visual)  # written last: its presence marks a complete cache entry
    return visual, parts


def cached_convex_parts(mesh: trimesh.Trimesh, kind: str, threshold: float, max_hulls: int,
                        folder: str = "meshes") -> tuple[Path, list[Path]]:
    """(visual mesh file, convex part files) of `mesh`: the shipped decomposition, else the user cache's,
    else a fresh CoACD run cached under `cache_dir(folder)`.

    threshold: CoACD's concavity threshold (lower is finer: more hulls, slower); max_hulls caps the parts.
    """
    name = f"{kind}_{mesh_key(mesh, [threshold, max_hulls])}"
    found = _entry(SHIPPED_DIR / name) or _entry(cache_dir(folder, name))
    return found or decompose(mesh, threshold, max_hulls, cache_dir(folder, name))
