"""Where the ManiLadder robot descriptions live, and their Panda mesh paths resolved for loading.

The generated URDFs in the repo's `agents/` folder (see scripts/make_agents.py) reference the Franka
and RealSense meshes of ManiSkill's bundled Panda as `package://franka_description/...` and
`package://realsense2_description/...`. SAPIEN resolves `package://` only by searching upwards from
the URDF's folder, so `urdf_path(name)` writes a copy with those paths made absolute (pointing into the
installed mani-skill wheel) into the ManiLadder cache and returns its path.

The wrist RealSense's visual mesh (`d415.stl`, 425k triangles) is swapped for its convex hull (12.6k
triangles, same outline to 0.1 mm at 128 px) in every loaded copy, ManiSkill's `panda_v3.urdf` included
(`panda_wristcam_urdf`). On lavapipe every camera draws every vertex in the scene, and that one mesh was
three quarters of a single-arm scene's vertices: a camera frame of PickPlacePen cost 2.4x PickCube-v1's
(measured: 88 vs 37 ms). Its collision shape is a box and is untouched, so physics is unchanged.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from mani_skill import PACKAGE_ASSET_DIR

from maniladder_ms.paths import AGENTS_DIR, cache_dir
PANDA_ASSET_DIR = Path(PACKAGE_ASSET_DIR) / "robots" / "panda"


CAMERA_MESH = "realsense2_description/meshes/d415.stl"


def camera_hull_path() -> Path:
    """The wrist camera's visual as the convex hull of the wheel's d415.stl, computed once per cache."""
    out = cache_dir("agents") / "d415_hull.stl"
    if not out.is_file():
        import trimesh

        hull = trimesh.load(PANDA_ASSET_DIR / CAMERA_MESH, force="mesh").convex_hull
        tmp = out.with_suffix(f".tmp{id(hull)}")
        hull.export(tmp, file_type="stl")
        tmp.replace(out)  # atomic, so parallel processes never read a half-written file
    return out


def _write_resolved(text: str, name: str) -> str:
    """`text` (a URDF whose mesh paths are absolute) with the camera hull swapped in, written to the cache."""
    text = text.replace(f"{PANDA_ASSET_DIR}/{CAMERA_MESH}", str(camera_hull_path()))
    # named by content: processes running other versions of this code never overwrite each other's copy
    out = cache_dir("agents") / f"{name}-{hashlib.sha1(text.encode()).hexdigest()[:12]}.urdf"
    if not out.is_file():
        tmp = out.with_suffix(f".tmp{id(text)}")
        tmp.write_text(text)
        tmp.replace(out)  # atomic, so parallel processes never read a half-written file
    return str(out)


def panda_wristcam_urdf() -> str:
    """ManiSkill's `panda_v3.urdf` (Panda + wrist RealSense; `ml_panda`) with the camera hull, loadable.

    Its mesh paths stay relative, through links to the wheel's mesh folders beside the copy: the Panda agent
    loads its collision meshes as multiple convex parts, and one loader resolves an absolute path against
    the URDF's folder (mplib, the solvers' motion planner, looked for `.../agents/work/main/...link0.stl.convex.stl`)."""
    folder = cache_dir("agents")
    for sub in ("franka_description", "realsense2_description"):
        link = folder / sub
        if not link.exists():
            tmp = folder / f".{sub}.tmp{os.getpid()}"
            tmp.unlink(missing_ok=True)
            tmp.symlink_to(PANDA_ASSET_DIR / sub, target_is_directory=True)
            tmp.replace(link)  # atomic, like the files
    text = (PANDA_ASSET_DIR / "panda_v3.urdf").read_text()
    out = _write_resolved(text.replace(f'filename="{CAMERA_MESH}"', f'filename="{PANDA_ASSET_DIR}/{CAMERA_MESH}"'), "panda_v3")
    srdf = Path(out).with_suffix(".srdf")  # mplib (the solvers' motion planner) reads the SRDF beside the URDF
    if not srdf.is_file():
        tmp = srdf.with_suffix(f".tmp{os.getpid()}")
        tmp.write_text((PANDA_ASSET_DIR / "panda_v3.srdf").read_text())
        tmp.replace(srdf)
    return out


def source_urdf(name: str) -> Path:
    path = AGENTS_DIR / f"{name}.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"robot description {path} is missing; run scripts/make_agents.py")
    return path


def urdf_path(name: str) -> str:
    """Path of the loadable URDF of robot `name` (agents/<name>.urdf with mesh paths resolved)."""
    return _write_resolved(source_urdf(name).read_text().replace("package://", f"{PANDA_ASSET_DIR}/"), name)
