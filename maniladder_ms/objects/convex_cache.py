"""CoACD convex decompositions of procedural meshes, computed once and cached on disk.

Keyed by the mesh itself and the decomposition settings, so any change to either recomputes.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import trimesh

from maniladder_ms.paths import cache_dir


def mesh_key(mesh: trimesh.Trimesh, settings: list) -> str:
    """Cache key of a mesh and the settings it is processed with."""
    digest = hashlib.sha1(np.round(mesh.vertices, 6).tobytes() + mesh.faces.tobytes())
    digest.update(json.dumps(settings).encode())
    return digest.hexdigest()[:16]


def cached_convex_parts(mesh: trimesh.Trimesh, kind: str, threshold: float, max_hulls: int,
                        folder: str = "meshes") -> tuple[Path, list[Path]]:
    """(visual mesh file, convex part files) of `mesh`, decomposing with CoACD on a cache miss.

    threshold: CoACD's concavity threshold (lower is finer: more hulls, slower); max_hulls caps the parts.
    """
    path = cache_dir(folder, f"{kind}_{mesh_key(mesh, [threshold, max_hulls])}")
    visual = path / "visual.obj"
    parts = sorted(path.glob("part_*.obj"))
    if visual.exists() and parts:
        return visual, parts
    import coacd

    coacd.set_log_level("error")
    hulls = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=threshold, max_convex_hull=max_hulls,
                            preprocess_mode="off", seed=0)
    parts = []
    for k, (v, f) in enumerate(hulls):
        part = path / f"part_{k:02d}.obj"
        trimesh.Trimesh(v, f).export(part)
        parts.append(part)
    mesh.export(visual)  # written last: its presence marks a complete cache entry
    return visual, parts
