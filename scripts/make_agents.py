#!/usr/bin/env python
"""Generate the URDFs of the ManiLadder embodiments under `agents/` (run from the repo root).

    .venv/bin/python scripts/make_agents.py          # writes agents/*.urdf
    .venv/bin/python scripts/make_agents.py --check  # exit 1 if a committed file is out of date

Outputs (all collision geometry is URDF primitives -- boxes and cylinders; the LEAP links' visuals are
the official finger meshes, decimated, in agents/meshes/leap/ (scripts/make_leap_meshes.py), named
relative to agents/ and resolved by maniladder_ms.agents.assets):

- `agents/ml_panda_leap.urdf`       Panda arm + right LEAP hand on the flange
- `agents/ml_dual_panda.urdf`       one articulation: a base plate and two Panda arms with grippers
- `agents/ml_dual_panda_leap.urdf`  one articulation: two Panda arms, left / right LEAP hands
- `agents/ml_tidybot.urdf`          holonomic base (x, y, yaw joints) carrying a Panda with gripper

The Panda parts are re-emitted from ManiSkill's bundled `panda_v3.urdf` (panda_v2 plus the wrist
RealSense mount) with their mesh paths turned into `package://franka_description/...` and
`package://realsense2_description/...`; `maniladder_ms.agents.assets` resolves those against the
installed mani-skill wheel at load time (the Franka meshes are not copied into this repo).

Sources of the numbers
----------------------
[LEAP-URDF] leap-hand/LEAP_Hand_Sim, assets/leap_hand/robot.urdf (commit e8fc513): joint origins
    (xyz / rpy), joint axes, joint limits, velocity / effort limits, link masses and inertias.
[LEAP-STL]  the link meshes of the same folder (dip/fingertip/mcp_joint/pip/thumb_*.stl): the
    axis-aligned bounding box of each mesh, placed with its URDF visual origin, measured in the link
    frame; each link collides as that box and is drawn with the mesh itself (decimated). palm_lower.stl is not in the public snapshot, so the
    palm box is bounded by the finger / thumb base joints of [LEAP-URDF] (see LEAP_PALM_BOX).
[LEAP-PAPER] Shaw, Agarwal, Pathak, "LEAP Hand: Low-Cost, Efficient, and Anthropomorphic Hand for
    Robot Learning", RSS 2023: 4 fingers x 4 joints (MCP side, MCP forward, PIP, DIP), thumb
    opposite the three fingers, right-handed layout.
[PANDA]     ManiSkill 3.0.1 `mani_skill/assets/robots/panda/panda_v3.urdf` (Franka's published
    kinematics): link/joint layout, flange (panda_link8) 0.107 m beyond joint 7, hand yaw -pi/4.
[TIDYBOT]   Wu et al., "TidyBot++: An Open-Source Holonomic Mobile Manipulator for Robot Learning",
    CoRL 2024 (arXiv 2412.10447): holonomic base on four powered casters (x, y, yaw all controlled);
    its Franka-Panda set-up documents the platform / arm base height as 0.47 m above the floor.
[MOBILE-LAYOUT] ManiSkill 3.0.1 `mobile_panda_single_arm.urdf`: root -> prismatic x -> prismatic
    y -> revolute yaw chain for a holonomic base (layout only).
[SCENE]     ManiLadder's table (maniladder_ms/envs/scene.py): top at z = 0, 0.8 m above the floor,
    front edge at x = -0.75; robots are placed at x = -0.615 on the centre line.
Values marked "(chosen)" are design choices of this repo, not published numbers.
"""

from __future__ import annotations

import argparse
import copy
import sys
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import mani_skill

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from maniladder_ms.agents.assets import LEAP_MESH_DIR, LEAP_WRIST_VIEW_TILT, LEAP_WRIST_VIEW_XYZ  # noqa: E402
OUT_DIR = REPO / "agents"
PANDA_URDF = Path(mani_skill.__file__).parent / "assets" / "robots" / "panda" / "panda_v3.urdf"

# ------------------------------------------------------------------------------------------------
# LEAP hand (right hand). Finger order and joint numbering as in [LEAP-URDF]:
#   index j0-j3, middle j4-j7, ring j8-j11, thumb j12-j15.
# Each finger chain is palm -(MCP forward)-> mcp -(MCP side)-> pip -(PIP)-> dip -(DIP)-> tip;
# the thumb is palm -> thumb_base -> thumb_pip -> thumb_dip -> thumb_tip  [LEAP-URDF].
# Joint entries: (joint number, parent segment, child segment, xyz, rpy, (lower, upper)). [LEAP-URDF]
# ------------------------------------------------------------------------------------------------
_FINGER_MCP_XYZ = {  # palm -> mcp_joint origins [LEAP-URDF], one per finger
    "index": ((-0.0070952496528625458, 0.023057756134899472, -0.018722403578460219), (1.5707963267948950, 1.5707963267948946, 0.0)),
    "middle": ((-0.0070952496528625389, -0.022392243865100525, -0.018722403578460230), (1.5707963267948966, 1.5707963267948966, 0.0)),
    "ring": ((-0.0070952454426398371, -0.067842243865100516, -0.018722407666402933), (1.5707963267948950, 1.5707963267948946, 0.0)),
}
_FINGER_FIRST_JOINT = {"index": 0, "middle": 4, "ring": 8}
# within a finger [LEAP-URDF]: mcp->pip (MCP side, joint n), pip->dip (PIP, n+2), dip->tip (DIP, n+3);
# palm->mcp is the MCP forward joint n+1
_MCP_TO_PIP = ((-0.0122, 0.0381, 0.0145), (-1.5707963267948966, 0.0, 1.5707963267948943))
_PIP_TO_DIP = ((0.015, 0.0143, -0.013), (1.5707963267948959, -1.5707963267948963, 0.0))
_DIP_TO_TIP = ((0.0, -0.0361, 0.0002), (0.0, 0.0, 0.0))
_LIMITS = {  # (lower, upper) rad [LEAP-URDF]
    "mcp_forward": (-0.314, 2.23),
    "mcp_side": (-1.047, 1.047),
    "pip": (-0.506, 1.885),
    "dip": (-0.366, 2.042),
    "thumb_base": (-0.349, 2.094),  # j12
    "thumb_pip": (-0.47, 2.443),  # j13
    "thumb_dip": (-1.20, 1.90),  # j14
    "thumb_tip": (-1.34, 1.88),  # j15
}
_THUMB = [  # (joint number, parent, child, xyz, rpy, limit key) [LEAP-URDF]
    (12, "palm", "thumb_base", (-0.069395249652862534, -0.0012422438651005258, -0.021622403578460216), (0.0, 1.5707963267948957, 0.0), "thumb_base"),
    (13, "thumb_base", "thumb_pip", (0.0, 0.0143, -0.013), (1.5707963267948959, -1.5707963267948963, 0.0), "thumb_pip"),
    (14, "thumb_pip", "thumb_dip", (0.0, 0.0145, -0.017), (-1.5707963267948966, 0.0, 0.0), "thumb_dip"),
    (15, "thumb_dip", "thumb_tip", (0.0, 0.0466, 0.0002), (0.0, 0.0, 3.141592653589793), "thumb_tip"),
]
LEAP_JOINT_AXIS = (0.0, 0.0, -1.0)  # every joint [LEAP-URDF]
LEAP_EFFORT = 0.95  # N m, Dynamixel XC330 stall torque as listed in [LEAP-URDF]
LEAP_VELOCITY = 8.48  # rad/s [LEAP-URDF]
# segment -> (mass kg, (ixx, iyy, izz, ixy, ixz, iyz)) [LEAP-URDF]
_SEGMENT_INERTIA = {
    "palm": (0.237, (0.000354094, 0.000260915, 0.000529257, -0.000001193, -0.000002445, -0.000002905)),
    "mcp": (0.044, (0.000011499, 0.000007796, 0.000014759, 0.000003049, 0.000000121, 0.000000112)),
    "pip": (0.032, (0.000004798, 0.000002862, 0.000004234, 0.000000012, 0.000000004, 0.000000011)),
    "dip": (0.037, (0.000005542, 0.000005727, 0.000006682, -0.000000607, -0.000000017, -0.000000023)),
    "tip": (0.016, (0.000003368, 0.000001556, 0.000002863, 0.000000115, 0.0, 0.0)),
    "thumb_base": (0.032, (0.000004798, 0.000002862, 0.000004234, 0.000000012, 0.000000004, 0.000000011)),
    "thumb_pip": (0.003, (0.000000593, 0.000000549, 0.000000224, 0.0, 0.0, 0.0)),
    "thumb_dip": (0.038, (0.000008474, 0.000003841, 0.000007679, 0.000000241, 0.000000026, 0.000000025)),
    "thumb_tip": (0.049, (0.000020372, 0.000004336, 0.000019845, -0.000000489, -0.00000003, -0.000000097)),
}
# segment -> link-frame bounding box (min xyz, max xyz) of its mesh, metres [LEAP-STL]
_SEGMENT_BOX = {
    "mcp": ((-0.0430, -0.0079, -0.0028), (0.0100, 0.0626, 0.0330)),
    "pip": ((-0.0095, -0.0145, -0.0230), (0.0245, 0.0151, 0.0000)),
    "dip": ((-0.0100, -0.0461, -0.0028), (0.0245, 0.0079, 0.0318)),
    "tip": ((-0.0111, -0.0495, -0.0028), (0.0100, 0.0079, 0.0318)),
    "thumb_base": ((-0.0245, -0.0145, -0.0230), (0.0095, 0.0151, 0.0000)),
    "thumb_pip": ((-0.0100, -0.0173, -0.0249), (0.0100, 0.0173, 0.0000)),
    "thumb_dip": ((-0.0185, -0.0095, -0.0316), (0.0100, 0.0545, 0.0030)),
    "thumb_tip": ((-0.0111, -0.0621, -0.0308), (0.0185, 0.0095, 0.0022)),
}
# Palm, in the palm frame: fingers point +x, the grasping side faces -z, the thumb sits at the wrist
# end (x ~ -0.08) on the +y side. Main box: x from the wrist end of the thumb base (-0.092
# [LEAP-STL], minus a 1 cm rim, chosen) to the MCP joints (-0.007 [LEAP-URDF]); y from the outer face
# of the ring MCP body (-0.101 [LEAP-STL]) to 0.012, short of the thumb links at rest (y >= 0.013
# [LEAP-STL]) so they never overlap the palm; z from the finger pads' plane (-0.031 [LEAP-STL], minus
# 4 mm, chosen) to the back of the MCP motors (0.024 [LEAP-STL]). A second box covers the index
# finger's base (y up to 0.026 [LEAP-STL]) ahead of the thumb (x > -0.06, chosen).
LEAP_PALM_BOXES = (((-0.102, -0.101, -0.035), (-0.007, 0.012, 0.024)),
                   ((-0.060, 0.012, -0.035), (-0.007, 0.026, 0.024)))
LEAP_PALM_BOX = ((-0.102, -0.101, -0.035), (-0.007, 0.026, 0.024))  # bounds of both, for placing the palm
# Flange adapter: a disc of the Panda flange's diameter (63 mm, ISO 9409-1-50-4-M6 per Franka's
# datasheet), 10 mm thick (chosen), between panda_link8 and the palm back; the palm is centred on the flange axis, fingers along the Panda hand's x axis (the Panda
# gripper is yawed -pi/4 about the flange [PANDA]; the LEAP hand uses the same yaw).
ADAPTER_RADIUS, ADAPTER_THICKNESS, ADAPTER_MASS = 0.0315, 0.01, 0.1
# "tcp" of the hand: where the centre of an object held in the "power" synergy sits, so that moving
# the tcp onto an object and closing the hand grasps it. Measured (not published): a 5 cm cube was
# lifted on 4/4 seeds for every offset within +-5 mm of this point, in a grid search over offsets and
# finger / thumb postures; it lies between the curled fingers and the thumb, 3 cm to the thumb side
# of the palm centre and 15 cm out from the flange. The left hand mirrors y.
LEAP_TCP_OFFSET = (0.03, -0.03, 0.15)
# Wrist camera link (chosen, first version): on the adapter rim at the wrist end of the palm, looking out
# along the flange axis, tilted 0.35 rad towards the fingers. From there the palm hid the grasp; the
# link (0.05 kg) stays here so that physics is unchanged, and the sensor and the camera's drawn body use
# LEAP_WRIST_VIEW (maniladder_ms/agents/assets.py) instead.
LEAP_CAMERA_XYZ = (-0.075, 0.0, 0.0)
LEAP_CAMERA_TILT = 0.35

# ------------------------------------------------------------------------------------------------
# Dual arm (chosen): both arm bases on the robot's root frame line (which the env places at
# x = -0.615 [SCENE]), 0.3 m left and right of it, facing +x; the bases are joined by an 0.8 m
# beam under the table top so that it is ONE articulation.
DUAL_ARM_Y = 0.3
# ------------------------------------------------------------------------------------------------
# TidyBot-style mobile base.
TIDYBOT_ARM_HEIGHT = 0.47  # arm base above the floor [TIDYBOT]
TIDYBOT_BASE_HALF = (0.25, 0.25)  # 0.5 m square footprint (chosen: TidyBot++ is a square frame of about this size)
TIDYBOT_BASE_MASS = 30.0  # kg (chosen)
TABLE_HEIGHT = 0.8  # [SCENE]
# The base frame (yaw joint) sits 0.42 m behind the root frame so the chassis front edge clears the
# table's front edge (root x -0.615, edge -0.75 [SCENE]: -0.615 - 0.42 + 0.25 = -0.785); the arm
# base is on top of the chassis, 0.17 m behind its front edge (chosen).
TIDYBOT_BASE_BEHIND_ROOT = 0.42
TIDYBOT_ARM_FORWARD = 0.08  # arm base ahead of the chassis centre (chosen)
TIDYBOT_CASTER_RADIUS = 0.05  # visual only (chosen)


# ------------------------------------------------------------------------------------------------
# URDF helpers
# ------------------------------------------------------------------------------------------------
def _fmt(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def _tf(xyz, rpy) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    m[:3, 3] = xyz
    return m


def _xyz_rpy(m: np.ndarray):
    # pitch = +-pi/2 frames (common in the LEAP description) trigger scipy's gimbal-lock warning; the
    # angles it returns still reproduce the matrix exactly (checked to 1e-15)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return m[:3, 3], Rotation.from_matrix(m[:3, :3]).as_euler("xyz")


MIRROR_Y = np.diag([1.0, -1.0, 1.0, 1.0])


class Urdf:
    def __init__(self, name: str):
        self.root = ET.Element("robot", name=name)
        self.materials = set()

    def material(self, name: str, rgba):
        if name not in self.materials:
            m = ET.SubElement(self.root, "material", name=name)
            ET.SubElement(m, "color", rgba=_fmt(rgba))
            self.materials.add(name)
        return name

    def link(self, name, mass=None, inertia=None, com=(0, 0, 0), shapes=(), meshes=()):
        """shapes: (kind, params, xyz, rpy, material, collide) with kind box (size) / cylinder (radius, length);
        collide: True (a visual and a collision shape), False (visual only) or "only" (collision only).
        meshes: (filename, material) visual meshes, placed at the link frame, written first."""
        link = ET.SubElement(self.root, "link", name=name)
        for filename, material in meshes:
            el = ET.SubElement(link, "visual")
            ET.SubElement(el, "origin", xyz="0 0 0", rpy="0 0 0")
            ET.SubElement(ET.SubElement(el, "geometry"), "mesh", filename=filename)
            ET.SubElement(el, "material", name=material)
        for kind, params, xyz, rpy, material, collide in shapes:
            tags = {True: ("visual", "collision"), False: ("visual",), "only": ("collision",)}[collide]
            for tag in tags:
                el = ET.SubElement(link, tag)
                ET.SubElement(el, "origin", xyz=_fmt(xyz), rpy=_fmt(rpy))
                geom = ET.SubElement(ET.SubElement(el, "geometry"), kind)
                if kind == "box":
                    geom.set("size", _fmt(params))
                else:
                    geom.set("radius", f"{params[0]:.9g}")
                    geom.set("length", f"{params[1]:.9g}")
                if tag == "visual" and material:
                    ET.SubElement(el, "material", name=material)
        if mass is not None:
            inertial = ET.SubElement(link, "inertial")
            ET.SubElement(inertial, "origin", xyz=_fmt(com), rpy="0 0 0")
            ET.SubElement(inertial, "mass", value=f"{mass:.9g}")
            ixx, iyy, izz, ixy, ixz, iyz = inertia
            ET.SubElement(inertial, "inertia", ixx=f"{ixx:.9g}", iyy=f"{iyy:.9g}", izz=f"{izz:.9g}",
                          ixy=f"{ixy:.9g}", ixz=f"{ixz:.9g}", iyz=f"{iyz:.9g}")
        return link

    def joint(self, name, kind, parent, child, xyz=(0, 0, 0), rpy=(0, 0, 0), axis=None, limit=None,
              effort=None, velocity=None, damping=None):
        j = ET.SubElement(self.root, "joint", name=name, type=kind)
        ET.SubElement(j, "origin", xyz=_fmt(xyz), rpy=_fmt(rpy))
        ET.SubElement(j, "parent", link=parent)
        ET.SubElement(j, "child", link=child)
        if axis is not None:
            ET.SubElement(j, "axis", xyz=_fmt(axis))
        if limit is not None or effort is not None:
            lim = ET.SubElement(j, "limit", effort=f"{effort or 0:.9g}", velocity=f"{velocity or 0:.9g}")
            if limit is not None:
                lim.set("lower", f"{limit[0]:.9g}")
                lim.set("upper", f"{limit[1]:.9g}")
        if damping is not None:
            ET.SubElement(j, "dynamics", damping=f"{damping:.9g}", friction="0")
        return j

    def append(self, element):
        self.root.append(element)

    def write(self, path: Path) -> str:
        ET.indent(self.root, space="  ")
        text = "<?xml version=\"1.0\"?>\n<!-- generated by scripts/make_agents.py; do not edit -->\n"
        return text + ET.tostring(self.root, encoding="unicode") + "\n"


def _box_inertia(mass, size):
    x, y, z = size
    return (mass * (y * y + z * z) / 12, mass * (x * x + z * z) / 12, mass * (x * x + y * y) / 12, 0.0, 0.0, 0.0)


# ------------------------------------------------------------------------------------------------
# Panda (re-emitted from ManiSkill's panda_v3.urdf)
# ------------------------------------------------------------------------------------------------
HAND_SUBTREE = {  # links beyond the flange that belong to the parallel gripper (+ wrist camera)
    "panda_hand", "panda_hand_tcp", "panda_leftfinger", "panda_rightfinger",
    "panda_leftfinger_pad", "panda_rightfinger_pad", "camera_base_link", "camera_link",
}


def add_panda(urdf: Urdf, prefix: str, parent: str | None, xyz=(0, 0, 0), rpy=(0, 0, 0), gripper=True):
    """Copy the Panda (arm, and the gripper + wrist camera if `gripper`) with names prefixed by `prefix`."""
    src = ET.parse(PANDA_URDF).getroot()
    for mat in src.findall("material"):
        if mat.get("name") not in urdf.materials:
            urdf.append(copy.deepcopy(mat))
            urdf.materials.add(mat.get("name"))
    keep = lambda name: gripper or name not in HAND_SUBTREE  # noqa: E731
    for el in src:
        if el.tag == "link" and keep(el.get("name")):
            link = copy.deepcopy(el)
            link.set("name", prefix + el.get("name"))
            for mesh in link.iter("mesh"):
                mesh.set("filename", "package://" + mesh.get("filename"))
            urdf.append(link)
        elif el.tag == "joint" and keep(el.find("child").get("link")):
            joint = copy.deepcopy(el)
            joint.set("name", prefix + el.get("name"))
            joint.find("parent").set("link", prefix + el.find("parent").get("link"))
            joint.find("child").set("link", prefix + el.find("child").get("link"))
            mimic = joint.find("mimic")
            if mimic is not None:
                mimic.set("joint", prefix + mimic.get("joint"))
            urdf.append(joint)
    if parent is not None:
        urdf.joint(f"{prefix}panda_base_joint", "fixed", parent, f"{prefix}panda_link0", xyz, rpy)


# ------------------------------------------------------------------------------------------------
# LEAP hand
# ------------------------------------------------------------------------------------------------
LEAP_COLORS = {"palm": (0.15, 0.15, 0.15, 1), "motor": (0.1, 0.1, 0.12, 1), "bone": (0.92, 0.92, 0.9, 1),
               "tip": (0.85, 0.3, 0.2, 1), "adapter": (0.6, 0.6, 0.62, 1)}


def add_leap_hand(urdf: Urdf, prefix: str, parent: str, palm_tf: np.ndarray, mirror: bool):
    """A LEAP hand (right, or left if `mirror`) whose palm frame is `palm_tf` in `parent`'s frame.

    Links are `{prefix}leap_palm`, `{prefix}leap_{finger}_{segment}`; joints `{prefix}leap_j{0..15}`.
    A left hand is the right hand reflected in its palm's x-z plane (y -> -y): joint frames T ->
    M T M, joint axes a -> -M a, box centres c -> M c, inertia products ixy, iyz negated.
    """
    for key, rgba in LEAP_COLORS.items():
        urdf.material(f"leap_{key}", rgba)
    m = MIRROR_Y if mirror else np.eye(4)

    def frame(xyz, rpy):
        return _xyz_rpy(m @ _tf(xyz, rpy) @ m)

    axis = -(m[:3, :3] @ np.array(LEAP_JOINT_AXIS)) if mirror else np.array(LEAP_JOINT_AXIS)

    def seg_link(name, segment, boxes, color):
        # collision: the boxes (unchanged since the boxes were also the visuals); visual: the link's mesh
        shapes = []
        for lo, hi in boxes:
            lo, hi = np.array(lo), np.array(hi)
            shapes.append(("box", hi - lo, m[:3, :3] @ ((lo + hi) / 2), (0, 0, 0), None, "only"))
        mass, (ixx, iyy, izz, ixy, ixz, iyz) = _SEGMENT_INERTIA[segment]
        if mirror:
            ixy, iyz = -ixy, -iyz
        mesh = f"{LEAP_MESH_DIR}/{'left' if mirror else 'right'}/{segment}.glb"
        urdf.link(name, mass, (ixx, iyy, izz, ixy, ixz, iyz), shapes=shapes, meshes=[(mesh, f"leap_{color}")])

    palm = f"{prefix}leap_palm"
    seg_link(palm, "palm", LEAP_PALM_BOXES, "palm")
    pxyz, prpy = _xyz_rpy(palm_tf)  # (for a left hand, the caller passes the reflected placement M P M)
    urdf.joint(f"{prefix}leap_palm_joint", "fixed", parent, palm, pxyz, prpy)

    def rev(n, parent_link, child_link, xyz, rpy, limit):
        fxyz, frpy = frame(xyz, rpy)
        urdf.joint(f"{prefix}leap_j{n}", "revolute", parent_link, child_link, fxyz, frpy, axis=axis,
                   limit=limit, effort=LEAP_EFFORT, velocity=LEAP_VELOCITY)

    for finger, (xyz, rpy) in _FINGER_MCP_XYZ.items():
        n = _FINGER_FIRST_JOINT[finger]
        names = {s: f"{prefix}leap_{finger}_{s}" for s in ("mcp", "pip", "dip", "tip")}
        for seg, color in (("mcp", "motor"), ("pip", "motor"), ("dip", "bone"), ("tip", "tip")):
            seg_link(names[seg], seg, [_SEGMENT_BOX[seg]], color)
        rev(n + 1, palm, names["mcp"], xyz, rpy, _LIMITS["mcp_forward"])
        rev(n, names["mcp"], names["pip"], *_MCP_TO_PIP, _LIMITS["mcp_side"])
        rev(n + 2, names["pip"], names["dip"], *_PIP_TO_DIP, _LIMITS["pip"])
        rev(n + 3, names["dip"], names["tip"], *_DIP_TO_TIP, _LIMITS["dip"])
    for n, par, child, xyz, rpy, lim in _THUMB:
        color = "tip" if child == "thumb_tip" else ("bone" if child == "thumb_dip" else "motor")
        seg_link(f"{prefix}leap_{child}", child, [_SEGMENT_BOX[child]], color)
        par_name = palm if par == "palm" else f"{prefix}leap_{par}"
        rev(n, par_name, f"{prefix}leap_{child}", xyz, rpy, _LIMITS[lim])


def add_leap_on_panda(urdf: Urdf, prefix: str, mirror: bool):
    """Flange adapter + LEAP hand + tcp + wrist camera on `{prefix}panda_link8`."""
    urdf.material("leap_adapter", LEAP_COLORS["adapter"])
    mount = f"{prefix}leap_mount"
    r = ADAPTER_RADIUS
    mass = ADAPTER_MASS
    urdf.link(mount, mass, (mass * (3 * r * r + ADAPTER_THICKNESS**2) / 12, mass * (3 * r * r + ADAPTER_THICKNESS**2) / 12,
                            mass * r * r / 2, 0, 0, 0), com=(0, 0, ADAPTER_THICKNESS / 2),
              shapes=[("cylinder", (r, ADAPTER_THICKNESS), (0, 0, ADAPTER_THICKNESS / 2), (0, 0, 0), "leap_adapter", True)])
    urdf.joint(f"{prefix}leap_mount_joint", "fixed", f"{prefix}panda_link8", mount, rpy=(0, 0, -np.pi / 4))
    # palm frame in the mount frame: palm -z (grasping side) along the flange axis (+z), palm back
    # on the adapter, palm box centred on the axis.
    lo, hi = np.array(LEAP_PALM_BOX[0]), np.array(LEAP_PALM_BOX[1])
    centre_back = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2]])
    rot = _tf((0, 0, 0), (np.pi, 0, 0))
    palm_tf = rot.copy()
    palm_tf[:3, 3] = np.array([0, 0, ADAPTER_THICKNESS]) - rot[:3, :3] @ centre_back
    if mirror:  # reflect the placement too, so the left palm is centred the same way
        palm_tf = MIRROR_Y @ palm_tf @ MIRROR_Y
    add_leap_hand(urdf, prefix, mount, palm_tf, mirror)
    urdf.link(f"{prefix}leap_tcp")
    tx, ty, tz = LEAP_TCP_OFFSET
    urdf.joint(f"{prefix}leap_tcp_joint", "fixed", mount, f"{prefix}leap_tcp", (tx, -ty if mirror else ty, tz))
    urdf.material("camera_grey", (0.3, 0.3, 0.32, 1))
    cam = f"{prefix}camera_link"
    # the camera link (its mass) stays where it was first placed, so physics is unchanged; its body is
    # drawn at the view the sensor uses (LEAP_WRIST_VIEW, in the mount frame; the sensor is mounted there)
    link_tf = _tf(LEAP_CAMERA_XYZ, (0, -np.pi / 2 + LEAP_CAMERA_TILT, 0))
    view_tf = _tf(LEAP_WRIST_VIEW_XYZ, (0, -np.pi / 2 + LEAP_WRIST_VIEW_TILT, 0))
    if mirror:  # the left hand's view is the mirror image (its rotation is about y: its own mirror image)
        view_tf = MIRROR_Y @ view_tf @ MIRROR_Y
    body_xyz, body_rpy = _xyz_rpy(np.linalg.inv(link_tf) @ view_tf @ _tf((-0.0125, 0, 0), (0, 0, 0)))
    urdf.link(cam, 0.05, _box_inertia(0.05, (0.025, 0.09, 0.025)),
              shapes=[("box", (0.025, 0.09, 0.025), body_xyz, body_rpy, "camera_grey", False)])
    # camera x axis (its viewing direction in ManiSkill) = mount +z tilted towards +x
    urdf.joint(f"{prefix}camera_joint", "fixed", mount, cam, LEAP_CAMERA_XYZ, (0, -np.pi / 2 + LEAP_CAMERA_TILT, 0))


# ------------------------------------------------------------------------------------------------
# Robots
# ------------------------------------------------------------------------------------------------
def panda_leap() -> Urdf:
    u = Urdf("ml_panda_leap")
    add_panda(u, "", None, gripper=False)
    add_leap_on_panda(u, "", mirror=False)
    return u


def _dual_base(u: Urdf):
    u.material("base_grey", (0.35, 0.35, 0.38, 1))
    size = (0.12, 2 * DUAL_ARM_Y + 0.2, 0.04)
    # beam under the table top (z < 0) joining the two arm bases: visual only, 10 kg (chosen)
    u.link("dual_base", 10.0, _box_inertia(10.0, size),
           shapes=[("box", size, (0, 0, -0.021), (0, 0, 0), "base_grey", False)])


def dual_panda(leap: bool) -> Urdf:
    u = Urdf("ml_dual_panda_leap" if leap else "ml_dual_panda")
    _dual_base(u)
    for side, y in (("left_", DUAL_ARM_Y), ("right_", -DUAL_ARM_Y)):
        add_panda(u, side, "dual_base", xyz=(0, y, 0), gripper=not leap)
        if leap:
            add_leap_on_panda(u, side, mirror=side == "left_")
    return u


def tidybot() -> Urdf:
    u = Urdf("ml_tidybot")
    u.material("base_grey", (0.35, 0.35, 0.38, 1))
    u.material("caster_black", (0.08, 0.08, 0.08, 1))
    # root (fixed to the world) -> x -> y -> yaw  [MOBILE-LAYOUT]; the base frame is on the floor
    u.link("root", 1.0, (0.01, 0.01, 0.01, 0, 0, 0))
    u.link("base_x_link", 1.0, (0.01, 0.01, 0.01, 0, 0, 0))
    u.link("base_y_link", 1.0, (0.01, 0.01, 0.01, 0, 0, 0))
    hx, hy = TIDYBOT_BASE_HALF
    deck_h = TIDYBOT_ARM_HEIGHT - 2 * TIDYBOT_CASTER_RADIUS
    shapes = [("box", (2 * hx, 2 * hy, deck_h), (0, 0, 2 * TIDYBOT_CASTER_RADIUS + deck_h / 2), (0, 0, 0), "base_grey", True)]
    for sx in (-1, 1):
        for sy in (-1, 1):  # four powered casters [TIDYBOT], visual only
            shapes.append(("cylinder", (TIDYBOT_CASTER_RADIUS, 0.04),
                           (sx * (hx - 0.06), sy * (hy - 0.06), TIDYBOT_CASTER_RADIUS), (np.pi / 2, 0, 0), "caster_black", False))
    size = (2 * hx, 2 * hy, TIDYBOT_ARM_HEIGHT)
    u.link("base_link", TIDYBOT_BASE_MASS, _box_inertia(TIDYBOT_BASE_MASS, size), com=(0, 0, TIDYBOT_ARM_HEIGHT / 2), shapes=shapes)
    u.joint("base_x_joint", "prismatic", "root", "base_x_link", (-TIDYBOT_BASE_BEHIND_ROOT, 0, -TABLE_HEIGHT),
            axis=(1, 0, 0), limit=(-10, 10), effort=1000, velocity=1.0)
    u.joint("base_y_joint", "prismatic", "base_x_link", "base_y_link", axis=(0, 1, 0), limit=(-10, 10), effort=1000, velocity=1.0)
    u.joint("base_yaw_joint", "continuous", "base_y_link", "base_link", axis=(0, 0, 1), effort=1000, velocity=3.14)
    add_panda(u, "", "base_link", xyz=(TIDYBOT_ARM_FORWARD, 0, TIDYBOT_ARM_HEIGHT), gripper=True)
    return u


ROBOTS = {
    "ml_panda_leap": panda_leap,
    "ml_dual_panda": lambda: dual_panda(False),
    "ml_dual_panda_leap": lambda: dual_panda(True),
    "ml_tidybot": tidybot,
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="only check that agents/ is up to date")
    args = parser.parse_args(argv)
    stale = []
    for name, build in ROBOTS.items():
        path = OUT_DIR / f"{name}.urdf"
        text = build().write(path)
        if args.check:
            if not path.exists() or path.read_text() != text:
                stale.append(path.name)
        else:
            path.write_text(text)
            print(f"wrote {path.relative_to(REPO)}")
    if stale:
        print("out of date: " + ", ".join(stale) + " (run scripts/make_agents.py)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
