"""Where the ManiLadder robot descriptions live, and their Panda mesh paths resolved for loading.

The generated URDFs in the repo's `agents/` folder (see scripts/make_agents.py) reference the Franka
and RealSense meshes of ManiSkill's bundled Panda as `package://franka_description/...` and
`package://realsense2_description/...`. SAPIEN resolves `package://` only by searching upwards from
the URDF's folder, so `urdf_path(name)` writes a copy with those paths made absolute (pointing into the
installed mani-skill wheel) into the ManiLadder cache and returns its path.
"""

from __future__ import annotations

from pathlib import Path

from mani_skill import PACKAGE_ASSET_DIR

from maniladder_ms.paths import AGENTS_DIR, cache_dir
PANDA_ASSET_DIR = Path(PACKAGE_ASSET_DIR) / "robots" / "panda"


def source_urdf(name: str) -> Path:
    path = AGENTS_DIR / f"{name}.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"robot description {path} is missing; run scripts/make_agents.py")
    return path


def urdf_path(name: str) -> str:
    """Path of the loadable URDF of robot `name` (agents/<name>.urdf with mesh paths resolved)."""
    text = source_urdf(name).read_text().replace("package://", f"{PANDA_ASSET_DIR}/")
    out = cache_dir("agents") / f"{name}.urdf"
    if not out.is_file() or out.read_text() != text:
        tmp = out.with_suffix(f".tmp{id(text)}")
        tmp.write_text(text)
        tmp.replace(out)  # atomic, so parallel processes never read a half-written file
    return str(out)
