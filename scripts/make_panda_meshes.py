"""Write the decimated Panda visual meshes committed in agents/meshes/panda/ (a one-off tool).

On lavapipe (CPU Vulkan) a camera frame costs roughly in proportion to the triangles in the scene, and the
Franka visual meshes of ManiSkill's bundled Panda (franka_description/meshes/visual/*.glb, exported flat
shaded: three vertices per triangle) are 135k triangles per arm. This script welds each material part,
decimates it with quadric edge collapse (fast-simplification), and re-shades it smooth with vertices
split at creases sharper than CREASE_DEG, so an arm's 135k triangles (398k vertices) become 17k (15k). Every
part keeps its own glTF material (white / black plastic, the coloured marks on link6: base colour,
metallic, roughness, double sided), so the robot looks the same at camera resolution.

fast-simplification is needed only here, never at run time (the package loads the committed .glb files):

    pip install --target /tmp/simp fast-simplification
    PYTHONPATH=/tmp/simp:. python scripts/make_panda_meshes.py           # rewrite agents/meshes/panda/
    PYTHONPATH=/tmp/simp:. python scripts/make_panda_meshes.py --check   # counts only, write nothing

(pip's --target copy brings numpy 2; delete /tmp/simp/numpy* so the venv's numpy is used: the extension
runs on either.) The output is the same bytes on every run with the same trimesh / fast-simplification.

Source meshes: franka_description (Franka Emika, Apache-2.0) as bundled in the mani-skill wheel.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import trimesh

REPO = Path(__file__).resolve().parents[1]
OUT_DIR = REPO / "agents" / "meshes" / "panda"
CAMERA_OUT = REPO / "agents" / "meshes" / "realsense" / "d415_hull.glb"
MESHES = ["link0", "link1", "link2", "link3", "link4", "link5", "link6", "link7", "hand", "finger"]
KEEP_FRACTION = 0.12  # triangles kept per part (of the welded mesh)
MIN_FACES = 1000  # parts this small (the finger, link6's coloured marks) are only welded, not decimated
CAMERA_KEEP_FRACTION = 0.05  # of the camera hull's triangles (the decimation stalls near 1.8k: fine)
CREASE_DEG = 35.0  # edges sharper than this stay hard (vertices split); the rest are smooth shaded


def source_dir() -> Path:
    from mani_skill import PACKAGE_ASSET_DIR

    return Path(PACKAGE_ASSET_DIR) / "robots" / "panda" / "franka_description" / "meshes" / "visual"


def simplify_part(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    import fast_simplification

    welded = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)  # merges coincident vertices
    v, f = welded.vertices, welded.faces
    if len(f) > MIN_FACES:
        v, f = fast_simplification.simplify(np.asarray(v, np.float32), np.asarray(f, np.int32),
                                            target_reduction=1.0 - KEEP_FRACTION)
    out = trimesh.Trimesh(v, f, process=True)
    out.update_faces(out.nondegenerate_faces())
    out.remove_unreferenced_vertices()
    shaded = trimesh.graph.smooth_shade(out, angle=np.radians(CREASE_DEG), facet_minarea=None)
    shaded.visual = trimesh.visual.TextureVisuals(material=mesh.visual.material)
    shaded.metadata = {}  # else smooth_shade's bookkeeping lands in the file as glTF extras
    return shaded


def make_camera() -> tuple[trimesh.Trimesh, int, int]:
    """The wrist RealSense's visual: the convex hull of d415.stl (425k triangles; the hull has 12.6k),
    decimated and re-hulled (1.6k triangles, within ~1.3 mm of the full hull), smooth shaded with creases.
    Its URDF visual names a material, which SAPIEN applies over the mesh's own, so the file needs none."""
    import fast_simplification

    src = trimesh.load(source_dir().parents[2] / "realsense2_description" / "meshes" / "d415.stl", force="mesh")
    hull = src.convex_hull
    v, f = fast_simplification.simplify(np.asarray(hull.vertices, np.float32), np.asarray(hull.faces, np.int32),
                                        target_reduction=1.0 - CAMERA_KEEP_FRACTION)
    light = trimesh.Trimesh(v, f).convex_hull
    shaded = trimesh.graph.smooth_shade(light, angle=np.radians(CREASE_DEG), facet_minarea=None)
    shaded.metadata = {}
    return shaded, (len(hull.faces), len(hull.faces) * 3), (len(shaded.faces), len(shaded.vertices))  # STL: 3 per triangle


def make(name: str) -> tuple[trimesh.Scene, tuple[int, int], tuple[int, int]]:
    """The light copy of visual mesh `name`, and (triangles, vertices) before and after."""
    scene = trimesh.load(source_dir() / f"{name}.glb")
    before = (sum(len(g.faces) for g in scene.geometry.values()), sum(len(g.vertices) for g in scene.geometry.values()))
    light = {key: simplify_part(geom) for key, geom in scene.geometry.items()}
    out = trimesh.Scene()  # rebuilt with fixed node names (trimesh's loaded ones are random): same bytes every run
    for node in sorted(scene.graph.nodes_geometry, key=lambda n: scene.graph[n][1]):  # by part name
        transform, key = scene.graph[node]
        out.add_geometry(light[key], geom_name=key, node_name=key, transform=transform)
    after = (sum(len(g.faces) for g in out.geometry.values()), sum(len(g.vertices) for g in out.geometry.values()))
    return out, before, after


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true", help="print the counts, write nothing")
    args = ap.parse_args(argv)
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    total_b, total_a = np.zeros(2, int), np.zeros(2, int)
    for name in MESHES:
        scene, before, after = make(name)
        total_b, total_a = total_b + before, total_a + after
        size = ""
        if not args.check:
            for g in scene.geometry.values():
                _ = g.vertex_normals  # cached, so the export carries the crease-split normals
            data = scene.export(file_type="glb", include_normals=True)
            (OUT_DIR / f"{name}.glb").write_bytes(data)
            size = f"  {len(data) / 1024:.0f} KiB"
        print(f"{name:7s} triangles {before[0]:6d} -> {after[0]:5d}, vertices {before[1]:6d} -> {after[1]:5d}{size}")
    print(f"Panda   triangles {total_b[0]:6d} -> {total_a[0]:5d} ({total_a[0] / total_b[0]:.1%}), "
          f"vertices {total_b[1]:6d} -> {total_a[1]:5d} ({total_a[1] / total_b[1]:.1%}) per arm (one finger)")
    camera, before, after = make_camera()
    size = ""
    if not args.check:
        _ = camera.vertex_normals
        data = camera.export(file_type="glb", include_normals=True)
        (CAMERA_OUT.parent).mkdir(parents=True, exist_ok=True)
        CAMERA_OUT.write_bytes(data)
        size = f"  {len(data) / 1024:.0f} KiB"
    print(f"d415    triangles {before[0]:6d} -> {after[0]:5d}, vertices {before[1]:6d} -> {after[1]:5d}{size}  (its hull)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
