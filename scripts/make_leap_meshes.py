"""Write the LEAP hand visual meshes committed in agents/meshes/leap/ (a one-off tool, like make_panda_meshes.py).

Source: leap-hand/LEAP_Hand_Sim (MIT, Copyright 2023 Ananye Agarwal), assets/leap_hand/: the finger STL
meshes (mcp_joint, pip, dip, fingertip, thumb_pip, thumb_dip, thumb_fingertip; 9k-32k triangles each) and
robot.urdf, whose <visual><origin> places each mesh in its link frame. Our LEAP joint frames are the official
ones (scripts/make_agents.py, [LEAP-URDF]), so each mesh is placed with its official visual origin and the
result is written in the link frame (the URDF visual origin is then the identity). Check: the placed meshes'
bounding boxes are our collision boxes (_SEGMENT_BOX, measured from the same meshes) to 0.1 mm; this script
asserts it. Each mesh is welded, quadric-decimated (fast-simplification) to about TARGET_FACES triangles and
smooth shaded with creases kept (see decimate: remeshed first). The left hand's files are the right hand's reflected in the palm's x-z plane
(y -> -y, winding flipped), as make_agents.py reflects the left hand's frames.

The palm mesh (palm_lower.stl) is not in the public snapshot, so the palm is procedural: the two palm boxes
of make_agents.py (LEAP_PALM_BOXES, also its collision shapes) with chamfered edges, drawn dark grey like the
real hand's printed frame.

    git --git-dir=<mirror of leap-hand/LEAP_Hand_Sim> archive HEAD assets/leap_hand | tar -x -C /tmp/leap
    pip install --target /tmp/simp fast-simplification; pip install --no-deps --target /tmp/simp pymcubes  # then delete /tmp/simp/numpy* (see make_panda_meshes.py)
    PYTHONPATH=/tmp/simp:. python scripts/make_leap_meshes.py /tmp/leap/assets/leap_hand          # write
    PYTHONPATH=/tmp/simp:. python scripts/make_leap_meshes.py /tmp/leap/assets/leap_hand --check  # counts only

The files carry no material: the URDF visual names one (LEAP_COLORS in make_agents.py), which SAPIEN applies.
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import trimesh

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))
import make_agents  # noqa: E402  (the segment boxes, the palm boxes, the frame helpers)

OUT_DIR = REPO / "agents" / "meshes" / "leap"
# our segment -> the official link whose visual it takes (the thumb's first link carries pip.stl)
SEGMENT_LINK = {"mcp": "mcp_joint", "pip": "pip", "dip": "dip", "tip": "fingertip", "thumb_base": "pip_4",
                "thumb_pip": "thumb_pip", "thumb_dip": "thumb_dip", "thumb_tip": "thumb_fingertip"}
TARGET_FACES = 300  # triangles per link (600, 9.7k per hand, cost LiftBottleHand ~40% of its RGB steps/s, loaded)
CREASE_DEG = 60.0  # edges sharper than this stay hard (few: split vertices cost render time)
PALM_CHAMFER = 0.006  # m (chosen)
VOXEL_PITCH = 0.0007  # m
VOXEL_BLUR = 0.8  # voxels (Gaussian sigma)


def official_visuals(src: Path) -> dict[str, tuple[str, np.ndarray]]:
    """segment -> (mesh file, visual origin as a 4x4) from the official robot.urdf."""
    links = {link.get("name"): link for link in ET.parse(src / "robot.urdf").getroot().findall("link")}
    out = {}
    for segment, name in SEGMENT_LINK.items():
        visual = links[name].find("visual")
        origin = visual.find("origin")
        xyz = [float(v) for v in origin.get("xyz").split()]
        rpy = [float(v) for v in origin.get("rpy").split()]
        out[segment] = (visual.find("geometry/mesh").get("filename"), make_agents._tf(xyz, rpy))
    return out


def shade(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.remove_unreferenced_vertices()
    shaded = trimesh.graph.smooth_shade(mesh, angle=np.radians(CREASE_DEG), facet_minarea=None)
    shaded.metadata = {}  # else smooth_shade's bookkeeping lands in the file as glTF extras
    return shaded


def decimate(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Remesh, then decimate. Quadric decimation of the STLs themselves stalls near 1.8k triangles (the
    printed parts have screw holes, slots and motor cavities) with a quarter of the volume eaten, so the mesh
    is first voxelized (VOXEL_PITCH, interior filled), its occupancy blurred (VOXEL_BLUR voxels) and re-meshed
    with marching cubes (PyMCubes): a closed surface without the sub-millimetre features, which then
    decimates cleanly to TARGET_FACES (bounding box within 2.5 mm of the source)."""
    import fast_simplification
    import mcubes
    from scipy import ndimage

    welded = trimesh.Trimesh(mesh.vertices, mesh.faces, process=True)  # merges coincident vertices
    grid = welded.voxelized(VOXEL_PITCH).fill()
    field = ndimage.gaussian_filter(np.pad(grid.matrix, 2).astype(float), VOXEL_BLUR)
    v, f = mcubes.marching_cubes(field, 0.5)
    surface = trimesh.Trimesh(trimesh.transform_points(v - 2, grid.transform), f, process=True)
    v, f = fast_simplification.simplify(np.asarray(surface.vertices, np.float32), np.asarray(surface.faces, np.int32),
                                        target_count=TARGET_FACES)
    out = trimesh.Trimesh(v, f, process=True)
    assert np.allclose(out.bounds, welded.bounds, atol=2.5e-3), (out.bounds, welded.bounds)
    return out


def chamfered_box(lo, hi, r: float) -> trimesh.Trimesh:
    """The convex hull of three copies of the box, each inset by `r` on two axes: a box with 45-degree
    chamfers of width `r` on its edges and corners."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    corners = []
    for axis in range(3):
        inset = np.full(3, r)
        inset[axis] = 0.0
        a, b = lo + inset, hi - inset
        corners += [[(a, b)[i][0], (a, b)[j][1], (a, b)[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    return trimesh.convex.convex_hull(np.array(corners))


def palm() -> trimesh.Trimesh:
    return trimesh.util.concatenate([chamfered_box(lo, hi, PALM_CHAMFER) for lo, hi in make_agents.LEAP_PALM_BOXES])


def build(src: Path) -> dict[str, tuple[trimesh.Trimesh, int]]:
    """segment -> (right-hand mesh in the link frame, source triangles)."""
    out = {}
    for segment, (filename, origin) in official_visuals(src).items():
        mesh = trimesh.load(src / filename, force="mesh")
        n_src = len(mesh.faces)
        mesh.apply_transform(origin)
        lo, hi = make_agents._SEGMENT_BOX[segment]
        assert np.allclose(mesh.bounds, [lo, hi], atol=1e-4), (segment, mesh.bounds, (lo, hi))
        out[segment] = (decimate(mesh), n_src)
    out["palm"] = (palm(), 0)
    return out


def mirrored(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    m = mesh.copy()
    m.apply_transform(make_agents.MIRROR_Y)  # trimesh flips the winding of a reflection
    return m


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("source", type=Path, help="LEAP_Hand_Sim's assets/leap_hand folder (robot.urdf + STLs)")
    ap.add_argument("--check", action="store_true", help="print the counts, write nothing")
    args = ap.parse_args(argv)
    total = np.zeros(2, int)
    for segment, (mesh, n_src) in build(args.source).items():
        for side, m in (("right", mesh), ("left", mirrored(mesh))):
            shaded = shade(m)
            if side == "right":  # a hand has three of each finger segment
                total += (3 if segment in ("mcp", "pip", "dip", "tip") else 1) * np.array([len(shaded.faces), len(shaded.vertices)])
            if not args.check:
                _ = shaded.vertex_normals  # cached, so the export carries the crease-split normals
                (OUT_DIR / side).mkdir(parents=True, exist_ok=True)
                (OUT_DIR / side / f"{segment}.glb").write_bytes(shaded.export(file_type="glb", include_normals=True))
        print(f"{segment:10s} triangles {n_src:6d} -> {len(shaded.faces):4d}, vertices {len(shaded.vertices):4d}")
    print(f"one hand: {total[0]} triangles, {total[1]} vertices")
    return 0


if __name__ == "__main__":
    sys.exit(main())
