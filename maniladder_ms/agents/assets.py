"""Where the ManiLadder robot descriptions live, and their Panda mesh paths resolved for loading.

The generated URDFs in the repo's `agents/` folder (see scripts/make_agents.py) reference the Franka
and RealSense meshes of ManiSkill's bundled Panda as `package://franka_description/...` and
`package://realsense2_description/...`. SAPIEN resolves `package://` only by searching upwards from
the URDF's folder, so `urdf_path(name)` writes a copy with those paths made absolute (pointing into the
installed mani-skill wheel) into the ManiLadder cache and returns its path.

Light visuals (one home: `_write_resolved`, which every loaded copy goes through, ManiSkill's
`panda_v3.urdf` for `ml_panda` included). On lavapipe (CPU Vulkan) every camera draws every triangle in
the scene, and a camera frame costs roughly in proportion to them. The stock visuals were 148k triangles
(437k vertices: exported flat shaded) per arm: the Franka link/hand/finger .glb files and the wrist
RealSense (`d415.stl`, 425k triangles, already replaced by its 12.6k-triangle convex hull). Every loaded
URDF now uses the decimated copies committed in `agents/meshes/` (scripts/make_panda_meshes.py: each
material part welded, quadric-decimated to 12% of its triangles, smooth shaded with creases kept, its
glTF material kept; the camera is its hull decimated to 1.6k triangles): 19k triangles / 16k vertices per
arm. Measured, 128 px, the three scene cameras, median capture per camera (loaded 2-core machine, same
conditions; PickCube-v1's camera: 74 ms there, 37 ms on a quiet one): PickPlacePen 63 -> 15 ms,
HandoverCube 119 -> 23 ms, LiftBasketHands 102 -> 21 ms. Only `<visual>` mesh paths change: collision
shapes and everything physical are as written, so physics and the committed demos are unchanged.
The LEAP hands' links are drawn with the official finger meshes, decimated to 300 triangles each
(`agents/meshes/leap/`, scripts/make_leap_meshes.py; 4.9k triangles / 4.4k vertices per hand); the generated
URDFs name them relative to agents/ and `_write_resolved` makes the paths absolute. Their links collide as
the boxes they were drawn as before. RGB steps/s (`maniladder bench --obs-mode rgb`, ratio to PickCube-v1,
2-core machine at load 3-13, so +-20% noise): LiftBottleHand 2.89 / 2.38 (boxes) -> 2.11 (meshes),
LiftBasketHands 1.29 / 0.96 -> 1.47.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from mani_skill import PACKAGE_ASSET_DIR

from maniladder_ms.paths import AGENTS_DIR, cache_dir
PANDA_ASSET_DIR = Path(PACKAGE_ASSET_DIR) / "robots" / "panda"


CAMERA_MESH = "realsense2_description/meshes/d415.stl"
PANDA_VISUAL_DIR = "franka_description/meshes/visual"
PANDA_VISUALS = ("link0", "link1", "link2", "link3", "link4", "link5", "link6", "link7", "hand", "finger")
# the decimated visuals, committed (written by scripts/make_panda_meshes.py); a wheel carries them
LIGHT_MESH_DIR = AGENTS_DIR / "meshes"
# the LEAP hands' visuals (scripts/make_leap_meshes.py: the official finger meshes, decimated, in their link
# frames; left/ and right/): the generated URDFs name them relative to agents/, as `meshes/leap/...`
LEAP_MESH_DIR = "meshes/leap"
# The LEAP wrist cameras' view (chosen), in the right hand's flange adapter frame (`leap_mount`: z along the
# flange axis, out of the arm; fingers along +x; the palm spans x -0.048..0.048, z 0.01..0.069; the thumb
# and index finger on the -y side): 3 cm behind the palm's wrist end, 2.6 cm beyond its grasping face, on the
# ring finger's side (away from the thumb, which otherwise fills the view), looking along the flange axis
# tilted 1.15 rad towards the fingers: the fingertips and the held object (the tcp, 15 cm out) are in view
# rather than the palm. A left hand's is the mirror image (y -> -y). The sensor is mounted there
# (agents/robots.py); the camera link, its mass, stays where it was (scripts/make_agents.py), so physics is
# unchanged.
LEAP_WRIST_VIEW_XYZ = (-0.08, 0.035, 0.095)
LEAP_WRIST_VIEW_TILT = 1.15


def camera_hull_path() -> Path:
    """The wrist camera's light visual: the convex hull of d415.stl, decimated (committed, see LIGHT_MESH_DIR)."""
    return LIGHT_MESH_DIR / "realsense" / "d415_hull.glb"


def _write_resolved(text: str, name: str) -> str:
    """`text` (a URDF whose mesh paths are absolute) with the light visuals swapped in, written to the cache.

    The one place where visual meshes are substituted (every loaded URDF goes through here); collision
    meshes and everything physical stay as written. See the module docstring for the measured costs.
    """
    text = text.replace(f"{PANDA_ASSET_DIR}/{CAMERA_MESH}", str(camera_hull_path()))
    text = text.replace(f'filename="{LEAP_MESH_DIR}/', f'filename="{AGENTS_DIR / LEAP_MESH_DIR}/')  # made absolute
    for mesh in PANDA_VISUALS:  # decimated Franka visuals: 17k triangles per arm instead of 135k
        text = text.replace(f'filename="{PANDA_ASSET_DIR}/{PANDA_VISUAL_DIR}/{mesh}.glb"',
                            f'filename="{LIGHT_MESH_DIR / "panda" / mesh}.glb"')
    # named by content: processes running other versions of this code never overwrite each other's copy
    out = cache_dir("agents") / f"{name}-{hashlib.sha1(text.encode()).hexdigest()[:12]}.urdf"
    if not out.is_file():
        _write_atomic(out, text)
    return str(out)


def _write_atomic(path: Path, text: str) -> None:
    """Write via a temporary file and a rename, so parallel processes never read a half-written file."""
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(text)
    tmp.replace(path)


def panda_wristcam_urdf() -> str:
    """ManiSkill's `panda_v3.urdf` (Panda + wrist RealSense; `ml_panda`) with the light visuals, loadable.

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
    for visual in (CAMERA_MESH, *(f"{PANDA_VISUAL_DIR}/{m}.glb" for m in PANDA_VISUALS)):  # absolute, to be swapped
        text = text.replace(f'filename="{visual}"', f'filename="{PANDA_ASSET_DIR}/{visual}"')
    out = _write_resolved(text, "panda_v3")
    srdf = Path(out).with_suffix(".srdf")  # mplib (the solvers' motion planner) reads the SRDF beside the URDF
    if not srdf.is_file():
        _write_atomic(srdf, (PANDA_ASSET_DIR / "panda_v3.srdf").read_text())
    return out


def source_urdf(name: str) -> Path:
    path = AGENTS_DIR / f"{name}.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"robot description {path} is missing; run scripts/make_agents.py")
    return path


def urdf_path(name: str) -> str:
    """Path of the loadable URDF of robot `name` (agents/<name>.urdf with mesh paths resolved)."""
    return _write_resolved(source_urdf(name).read_text().replace("package://", f"{PANDA_ASSET_DIR}/"), name)
