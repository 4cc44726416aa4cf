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

import re
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
    out = cache_dir("agents") / f"{name}.urdf"
    if not out.is_file() or out.read_text() != text:
        tmp = out.with_suffix(f".tmp{id(text)}")
        tmp.write_text(text)
        tmp.replace(out)  # atomic, so parallel processes never read a half-written file
    return str(out)


def panda_wristcam_urdf() -> str:
    """ManiSkill's `panda_v3.urdf` (Panda + wrist RealSense; `ml_panda`) with the camera hull, loadable."""
    text = (PANDA_ASSET_DIR / "panda_v3.urdf").read_text()
    text = re.sub(r'filename="(franka_description|realsense2_description)/', rf'filename="{PANDA_ASSET_DIR}/\1/', text)
    return _write_resolved(text, "panda_v3")


def source_urdf(name: str) -> Path:
    path = AGENTS_DIR / f"{name}.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"robot description {path} is missing; run scripts/make_agents.py")
    return path


def urdf_path(name: str) -> str:
    """Path of the loadable URDF of robot `name` (agents/<name>.urdf with mesh paths resolved)."""
    return _write_resolved(source_urdf(name).read_text().replace("package://", f"{PANDA_ASSET_DIR}/"), name)
