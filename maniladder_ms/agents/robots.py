"""The five ManiLadder embodiments as ManiSkill agents (registered on import).

| uid | suite | what |
|---|---|---|
| `ml_panda` | SG | Panda + parallel gripper + wrist camera (ManiSkill's bundled Panda description) |
| `ml_panda_leap` | SX | Panda arm + 16-DoF right LEAP hand |
| `ml_dual_panda` | DG | two Pandas with grippers, 0.3 m left / right of the robot frame, one articulation |
| `ml_dual_panda_leap` | DX | two Panda arms with a left / right LEAP hand, one articulation |
| `ml_tidybot` | mobile | holonomic base (x, y, yaw) + Panda + gripper |

Every agent offers ManiSkill's eleven Panda control modes (`CONTROL_MODES`, docs/control-modes.md), one flat
action vector each (the class docstrings lay out the three the solvers use), a `rest` keyframe and wrist
cameras. Arm gains are ManiSkill's Panda gains. The generated descriptions are in the repo's `agents/` folder
(scripts/make_agents.py).
"""

from __future__ import annotations

from collections import deque
from copy import deepcopy
import xml.etree.ElementTree as ET

import numpy as np
import sapien
import torch

from mani_skill.agents.base_agent import BaseAgent, Keyframe
from mani_skill.agents.controllers import (
    PDBaseVelControllerConfig,
    PDEEPosControllerConfig,
    PDEEPoseControllerConfig,
    PDJointPosControllerConfig,
    PDJointPosMimicControllerConfig,
    PDJointPosVelControllerConfig,
    PDJointVelControllerConfig,
    deepcopy_dict,
)
from mani_skill.agents.registration import register_agent
from mani_skill.agents.robots.panda.panda_wristcam import PandaWristCam
from mani_skill.sensors.camera import CameraConfig

from .assets import LEAP_WRIST_VIEW_TILT, LEAP_WRIST_VIEW_XYZ, panda_wristcam_urdf, source_urdf, urdf_path

ARM_JOINTS = [f"panda_joint{i}" for i in range(1, 8)]
GRIPPER_JOINTS = ["panda_finger_joint1", "panda_finger_joint2"]
LEAP_JOINTS = [f"leap_j{i}" for i in range(16)]  # LEAP numbering: index 0-3, middle 4-7, ring 8-11, thumb 12-15
# ManiSkill's Panda rest pose (arm) and the gripper open
PANDA_REST = [0.0, np.pi / 8, 0.0, -np.pi * 5 / 8, 0.0, np.pi * 3 / 4, np.pi / 4]
GRIPPER_OPEN = 0.04
TIDYBOT_ARM_REST = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, np.pi / 4]

ARM_STIFFNESS, ARM_DAMPING, ARM_FORCE = 1e3, 1e2, 100  # ManiSkill's Panda
GRIPPER_STIFFNESS, GRIPPER_DAMPING, GRIPPER_FORCE = 1e3, 1e2, 100  # ManiSkill's Panda
# LEAP: stiff enough to hold a 300 g object with 4 fingers, force limited to 2x the servo's 0.95 N m
# (its stall torque; the hand's joints carry the extra load in simulation where contact is softer)
LEAP_STIFFNESS, LEAP_DAMPING, LEAP_FORCE = 30.0, 1.0, 1.9
BASE_DAMPING, BASE_FORCE = 1000.0, 1000.0  # base velocity drive (as ManiSkill's Fetch base)
BASE_MAX_VEL = (0.5, 0.5, 1.57)  # m/s, m/s, rad/s of the holonomic base (chosen)

# LEAP contact materials: the fingertips' rubber pads grip hardest; the printed finger segments get a
# plastic-on-plastic friction high enough that a power grasp, which touches mostly the segments, holds
LEAP_TIP_FRICTION, LEAP_SEGMENT_FRICTION = 2.0, 1.0
LEAP_SEGMENTS = [f"{f}_{s}" for f in ("index", "middle", "ring") for s in ("mcp", "pip", "dip")] + \
    ["thumb_base", "thumb_pip", "thumb_dip"]


def leap_urdf_config(prefixes=("",)) -> dict:
    """ManiSkill urdf_config giving each LEAP hand's tips and segments their contact materials."""
    materials = dict(tip=dict(static_friction=LEAP_TIP_FRICTION, dynamic_friction=LEAP_TIP_FRICTION, restitution=0.0),
                     segment=dict(static_friction=LEAP_SEGMENT_FRICTION, dynamic_friction=LEAP_SEGMENT_FRICTION,
                                  restitution=0.0))
    links = {}
    for prefix in prefixes:
        for finger in ("index", "middle", "ring", "thumb"):
            links[f"{prefix}leap_{finger}_tip"] = dict(material="tip", patch_radius=0.05, min_patch_radius=0.05)
        for segment in LEAP_SEGMENTS:
            links[f"{prefix}leap_{segment}"] = dict(material="segment")
    return dict(_materials=materials, link=links)


def urdf_joint_order(path) -> list[str]:
    """Active joints of a URDF in SAPIEN's order (breadth-first from the root, children in file order)."""
    root = ET.parse(path).getroot()
    children: dict[str, list] = {}
    child_links = set()
    for j in root.findall("joint"):
        children.setdefault(j.find("parent").get("link"), []).append(j)
        child_links.add(j.find("child").get("link"))
    base = next(link.get("name") for link in root.findall("link") if link.get("name") not in child_links)
    order, queue = [], deque([base])
    while queue:
        for j in children.get(queue.popleft(), []):
            if j.get("type") != "fixed":
                order.append(j.get("name"))
            queue.append(j.find("child").get("link"))
    return order


def rest_keyframe(name: str, values: dict[str, float], pose=None) -> Keyframe:
    order = urdf_joint_order(source_urdf(name))
    return Keyframe(qpos=np.array([values.get(j, 0.0) for j in order]), pose=pose or sapien.Pose())


# ---- controller configs ------------------------------------------------------------------------
# The control modes of the agents built here, the default (`pd_joint_pos`) first: ManiSkill's eleven Panda modes
# (`ml_panda` is ManiSkill's Panda: the same eleven, its default `pd_joint_delta_pos`). Only the arm part differs
# between modes; a gripper or LEAP hand keeps its joint-position targets and the TidyBot base its velocity command.
CONTROL_MODES = (
    "pd_joint_pos", "pd_joint_delta_pos", "pd_ee_delta_pose",  # the modes the solvers and demos use
    "pd_ee_delta_pos", "pd_ee_pose", "pd_joint_vel", "pd_joint_pos_vel", "pd_joint_delta_pos_vel",
    "pd_joint_target_delta_pos", "pd_ee_target_delta_pos", "pd_ee_target_delta_pose",
)


def arm_configs(joints: list[str], ee_link: str, urdf: str) -> dict:
    """The arm part of each of `CONTROL_MODES` for one Panda arm (`joints`, IK end link `ee_link`), as ManiSkill's
    Panda builds them (same gains and bounds): joint targets (absolute, delta, delta from the last target), joint
    velocities, joint targets + velocities, and the TCP by IK (delta position, delta pose, absolute pose; deltas
    also from the last target). TCP poses are in the articulation's root frame."""
    gains = dict(stiffness=ARM_STIFFNESS, damping=ARM_DAMPING, force_limit=ARM_FORCE)
    ik = dict(joint_names=joints, ee_link=ee_link, urdf_path=urdf, **gains)
    configs = dict(
        pd_joint_pos=PDJointPosControllerConfig(joints, None, None, **gains, normalize_action=False),
        pd_joint_delta_pos=PDJointPosControllerConfig(joints, -0.1, 0.1, **gains, use_delta=True),
        pd_ee_delta_pose=PDEEPoseControllerConfig(pos_lower=-0.1, pos_upper=0.1, rot_lower=-0.1, rot_upper=0.1, **ik),
        pd_ee_delta_pos=PDEEPosControllerConfig(pos_lower=-0.1, pos_upper=0.1, **ik),
        pd_ee_pose=PDEEPoseControllerConfig(pos_lower=-2.0, pos_upper=2.0, use_delta=False, normalize_action=False,
                                            **ik),
        # velocity drive: damping only (ManiSkill's Panda uses the arm's damping as its gain)
        pd_joint_vel=PDJointVelControllerConfig(joints, -1.0, 1.0, ARM_DAMPING, ARM_FORCE),
        pd_joint_pos_vel=PDJointPosVelControllerConfig(joints, None, None, **gains, normalize_action=False),
        pd_joint_delta_pos_vel=PDJointPosVelControllerConfig(joints, -0.1, 0.1, **gains, use_delta=True),
    )
    for mode in ("pd_joint_delta_pos", "pd_ee_delta_pos", "pd_ee_delta_pose"):
        target_mode = mode.replace("_delta_", "_target_delta_")  # deltas from the last target, not the state
        configs[target_mode] = deepcopy(configs[mode])
        configs[target_mode].use_target = True
    assert set(configs) == set(CONTROL_MODES)
    return configs


def gripper_config(prefix: str = ""):
    """Gripper: one normalised command, -1 -> finger target -0.01 m (closed), 1 -> 0.04 m (open) (ManiSkill's Panda)."""
    j1, j2 = prefix + GRIPPER_JOINTS[0], prefix + GRIPPER_JOINTS[1]
    return PDJointPosMimicControllerConfig(
        [j1, j2], lower=-0.01, upper=0.04, stiffness=GRIPPER_STIFFNESS, damping=GRIPPER_DAMPING,
        force_limit=GRIPPER_FORCE, mimic={j2: {"joint": j1}},
    )


def leap_config(prefix: str = ""):
    """LEAP hand joint targets (rad), absolute, within the joint limits, in LEAP order j0..j15."""
    return PDJointPosControllerConfig(
        [prefix + j for j in LEAP_JOINTS], None, None, LEAP_STIFFNESS, LEAP_DAMPING, LEAP_FORCE,
        normalize_action=False,
    )


def combine(**parts) -> dict:
    """{mode: {part: config}} for every one of `CONTROL_MODES`, from parts given as either a per-mode dict (an
    arm's `arm_configs`) or one config for all modes (a gripper, a hand, a base)."""
    out = {}
    for mode in CONTROL_MODES:
        out[mode] = {name: (p[mode] if isinstance(p, dict) else deepcopy(p)) for name, p in parts.items()}
    return deepcopy_dict(out)


def offered_control_modes(uid: str) -> tuple[str, ...]:
    """The control modes registered agent `uid` offers (any ManiSkill agent), its default first. Read from the
    agent class's controller configs without building the agent (they depend on class attributes only)."""
    from mani_skill.agents.registration import REGISTERED_AGENTS

    if uid not in REGISTERED_AGENTS:
        raise KeyError(f"no registered agent {uid!r}")
    cls = REGISTERED_AGENTS[uid].agent_cls
    return tuple(object.__new__(cls)._controller_configs)


def wrist_camera(uid: str, link, pose: sapien.Pose | None = None) -> CameraConfig:
    return CameraConfig(uid=uid, pose=pose or sapien.Pose(), width=128, height=128, fov=np.pi / 2, near=0.01,
                        far=100, mount=link)


def leap_wrist_camera(uid: str, mount, left: bool = False) -> CameraConfig:
    """A LEAP hand's wrist camera on its flange adapter `mount` (`<side>_leap_mount`), at LEAP_WRIST_VIEW
    (agents/assets.py): looking past the palm at the fingertips and the grasped object. The camera's x axis
    (its viewing direction) is the mount's +z tilted towards +x (the fingers), a rotation about the mount's y;
    a left hand's is the mirror image (y -> -y; a rotation about y is its own mirror image)."""
    angle = -np.pi / 2 + LEAP_WRIST_VIEW_TILT
    x, y, z = LEAP_WRIST_VIEW_XYZ
    return wrist_camera(uid, mount, sapien.Pose([x, -y if left else y, z], [np.cos(angle / 2), 0.0, np.sin(angle / 2), 0.0]))


class _MLAgent(BaseAgent):
    """Shared: loads agents/<uid>.urdf, checks the keyframe joint order, looks up named links."""

    arm_joint_names: list[str] = ARM_JOINTS

    # prefixes of the hands (LEAP hands, grippers) of the agents that need it; each hand's links (and the
    # `wrist_links` it sits on) share a collision-group bit so they do not collide with each other: the
    # published LEAP link meshes interleave at the joints, and their bounding boxes (our collision shapes)
    # overlap there
    hand_prefixes: tuple[str, ...] = ()
    HAND_GROUP_BITS = (25, 26)  # bits of PhysX collision group 2 (ManiSkill uses 29-31 elsewhere)
    # the links (besides a hand's `leap_*` links) that share its bit: the hand is also kept from the
    # forearm and wrist (links 5-7), as the Panda's SRDF does for its own hand. Random joint targets
    # otherwise fold the fingers into link 5, where restored states replay 80 rad/s apart
    wrist_links: tuple[str, ...] = ("camera_link", "panda_link5", "panda_link6", "panda_link7")

    def _after_loading_articulation(self):
        super()._after_loading_articulation()
        for prefix, bit in zip(self.hand_prefixes, self.HAND_GROUP_BITS):
            for link in self.robot.get_links():
                if link.name.startswith(prefix + "leap_") or link.name in [prefix + w for w in self.wrist_links]:
                    link.set_collision_group_bit(group=2, bit_idx=bit, bit=1)

    def _after_init(self):
        names = [j.name for j in self.robot.get_active_joints()]
        expected = urdf_joint_order(source_urdf(self.uid))
        assert names == expected, f"{self.uid}: joint order {names} != keyframe order {expected}"
        self._links = {link.name: link for link in self.robot.get_links()}

    def link(self, name: str):
        return self._links[name]

    @property
    def _sensor_configs(self):
        # one wrist camera; the two-arm agents override this with one per side
        return [wrist_camera("hand_camera", self.robot.links_map["camera_link"])]


# ==================================================================================================
@register_agent()
class MLPanda(PandaWristCam):
    """SG: Franka Panda + parallel gripper, wrist camera `hand_camera` (ManiSkill's `panda_wristcam`).

    Action layout (8 dims):
      pd_joint_pos        [0:7] arm joint targets (rad), [7] gripper (normalised: -1 closed, 1 open)
      pd_joint_delta_pos  [0:7] arm joint deltas (normalised, 1 = 0.1 rad), [7] gripper
      pd_ee_delta_pose    [0:3] TCP translation, [3:6] TCP rotation (XYZ Euler delta; ManiSkill 3.0.1 turns
                          the other way), both normalised (1 = 0.1 m / 0.1 rad, in the robot root frame), [6] gripper
    (ManiSkill's other Panda modes -- pd_ee_pose, pd_joint_vel, ... -- are available too: docs/control-modes.md.)
    """

    uid = "ml_panda"
    urdf_path = panda_wristcam_urdf()  # panda_v3.urdf with the low-poly wrist camera (agents/assets.py)


# ==================================================================================================
@register_agent()
class MLPandaLeap(_MLAgent):
    """SX: Panda arm + 16-DoF right LEAP hand on the flange; wrist camera `hand_camera`.

    The hand's palm faces along the flange axis (out of the arm), fingers along the Panda hand's x axis.
    TCP link `leap_tcp`: where a held object's centre sits in the "power" synergy, 15 cm out from the
    flange (see scripts/make_agents.py); move it onto an object, close the hand, and the object is grasped.

    Action layout (23 dims):
      pd_joint_pos        [0:7] arm joint targets (rad), [7:23] hand joint targets (rad)
      pd_joint_delta_pos  [0:7] arm joint deltas (normalised, 1 = 0.1 rad), [7:23] hand joint targets (rad)
      pd_ee_delta_pose    [0:6] TCP delta pose (as ml_panda), [6:22] hand joint targets (rad)
    Hand joints in LEAP order: index j0 (MCP side), j1 (MCP forward), j2 (PIP), j3 (DIP); middle
    j4-j7 and ring j8-j11 likewise; thumb j12 (base / opposition), j13, j14, j15 (tip). 0 = flat hand.
    The other control modes change the arm part only (docs/control-modes.md).
    """

    uid = "ml_panda_leap"
    hand_prefixes = ("",)
    urdf_path = urdf_path("ml_panda_leap")
    urdf_config = leap_urdf_config()
    hand_joint_names = LEAP_JOINTS
    ee_link_name = "leap_tcp"
    keyframes = dict(rest=rest_keyframe("ml_panda_leap", dict(zip(ARM_JOINTS, PANDA_REST))))

    @property
    def _controller_configs(self):
        return combine(arm=arm_configs(ARM_JOINTS, self.ee_link_name, self.urdf_path), hand=leap_config())

    def _after_init(self):
        super()._after_init()
        self.tcp = self.link(self.ee_link_name)
        self.palm = self.link("leap_palm")
        self.tip_links = [self.link(f"leap_{f}_tip") for f in ("index", "middle", "ring", "thumb")]

    @property
    def _sensor_configs(self):
        return [leap_wrist_camera("hand_camera", self.robot.links_map["leap_mount"])]


# ==================================================================================================
def _dual_rest(gripper: bool) -> dict:
    values = {}
    for side in ("left_", "right_"):
        values.update({side + j: v for j, v in zip(ARM_JOINTS, PANDA_REST)})
        if gripper:
            values.update({side + j: GRIPPER_OPEN for j in GRIPPER_JOINTS})
    return values


class _DualArm(_MLAgent):
    """Shared by the two-arm agents: one articulation, `left_`/`right_` prefixed arms, a wrist camera
    and an end effector (`_end_effector_config`, TCP link `<side>_<tcp_link>`) per side."""

    sides = ("left", "right")
    arm_joint_names = [s + j for s in ("left_", "right_") for j in ARM_JOINTS]
    tcp_link: str
    end_effector: str

    def _end_effector_config(self, prefix: str):
        raise NotImplementedError

    @property
    def _controller_configs(self):
        parts = {}
        for side in self.sides:
            p = side + "_"
            parts[f"{side}_arm"] = arm_configs([p + j for j in ARM_JOINTS], p + self.tcp_link, self.urdf_path)
            parts[f"{side}_{self.end_effector}"] = self._end_effector_config(p)
        return combine(**parts)

    @property
    def _sensor_configs(self):
        return [wrist_camera(f"{s}_hand_camera", self.robot.links_map[f"{s}_camera_link"]) for s in self.sides]

    def _after_init(self):
        super()._after_init()
        self.tcps = {s: self.link(f"{s}_{self.tcp_link}") for s in self.sides}


@register_agent()
class MLDualPanda(_DualArm):
    """DG: two Pandas with parallel grippers, ONE articulation (root `dual_base`), arm bases 0.3 m to the
    left (+y) and right (-y) of the robot frame, both facing +x. Wrist cameras `left_hand_camera`,
    `right_hand_camera`; TCP links `left_panda_hand_tcp`, `right_panda_hand_tcp`.

    Action layout (16 dims), left arm first:
      pd_joint_pos        [0:7] left arm joint targets, [7] left gripper, [8:15] right arm, [15] right gripper
      pd_joint_delta_pos  same with arm joint deltas (normalised, 1 = 0.1 rad)
      pd_ee_delta_pose    [0:6] left TCP delta pose, [6] left gripper, [7:13] right TCP delta pose,
                          [13] right gripper (delta poses normalised, 1 = 0.1 m / 0.1 rad, in the root frame)
    Gripper commands are normalised: -1 closed (finger target -0.01 m), 1 open (0.04 m).
    The other control modes change the arm part only (docs/control-modes.md).
    """

    uid = "ml_dual_panda"
    # the gripper and the wrist links do not collide with each other, as the Panda's SRDF (which
    # ManiSkill's single Panda loads) has it: folded wrists otherwise jam the hand into link 5
    hand_prefixes = ("left_", "right_")
    wrist_links = ("panda_hand", "panda_leftfinger", "panda_rightfinger", "camera_link", "panda_link5",
                   "panda_link6", "panda_link7")
    urdf_path = urdf_path("ml_dual_panda")
    urdf_config = dict(
        _materials=dict(gripper=dict(static_friction=2.0, dynamic_friction=2.0, restitution=0.0)),
        link={f"{s}panda_{f}finger": dict(material="gripper", patch_radius=0.1, min_patch_radius=0.1)
              for s in ("left_", "right_") for f in ("left", "right")},
    )
    keyframes = dict(rest=rest_keyframe("ml_dual_panda", _dual_rest(True)))
    tcp_link, end_effector = "panda_hand_tcp", "gripper"

    def _end_effector_config(self, prefix: str):
        return gripper_config(prefix)


@register_agent()
class MLDualPandaLeap(_DualArm):
    """DX: two Panda arms with LEAP hands (left hand on the left arm, right hand on the right), ONE
    articulation, arm bases as `ml_dual_panda`. Wrist cameras `left_hand_camera`, `right_hand_camera`;
    TCP links `left_leap_tcp`, `right_leap_tcp`.

    Action layout (46 dims), left side first:
      pd_joint_pos        [0:7] left arm joint targets, [7:23] left hand joint targets,
                          [23:30] right arm joint targets, [30:46] right hand joint targets (rad)
      pd_joint_delta_pos  same with arm joint deltas (normalised, 1 = 0.1 rad); hands absolute
      pd_ee_delta_pose    [0:6] left TCP delta pose, [6:22] left hand, [22:28] right TCP delta pose,
                          [28:44] right hand
    Hand joints in LEAP order j0..j15 (see ml_panda_leap); the left hand is the mirror image of the right,
    so the same joint values give the mirrored posture.
    The other control modes change the arm part only (docs/control-modes.md).
    """

    uid = "ml_dual_panda_leap"
    hand_prefixes = ("left_", "right_")
    urdf_path = urdf_path("ml_dual_panda_leap")
    urdf_config = leap_urdf_config(("left_", "right_"))
    keyframes = dict(rest=rest_keyframe("ml_dual_panda_leap", _dual_rest(False)))
    tcp_link, end_effector = "leap_tcp", "hand"

    def _end_effector_config(self, prefix: str):
        return leap_config(prefix)

    @property
    def _sensor_configs(self):
        return [leap_wrist_camera(f"{s}_hand_camera", self.robot.links_map[f"{s}_leap_mount"], left=s == "left")
                for s in self.sides]


# ==================================================================================================
@register_agent()
class MLTidyBot(_MLAgent):
    """Mobile: TidyBot++-style holonomic base carrying a Panda with gripper; wrist camera `hand_camera`.

    Base joints `base_x_joint`, `base_y_joint` (prismatic, world-aligned) and `base_yaw_joint` sit on the
    floor 0.42 m behind the robot frame (so the 0.5 m square chassis clears the table); the arm base is
    0.47 m above the floor on the chassis. TCP link `panda_hand_tcp`.

    Action layout (11 dims):
      pd_joint_pos        [0:3] base velocity (vx, vy in the base's own frame, yaw rate; normalised,
                          1 = 0.5 m/s, 0.5 m/s, 1.57 rad/s), [3:10] arm joint targets (rad), [10] gripper
      pd_joint_delta_pos  [0:3] base velocity, [3:10] arm joint deltas (1 = 0.1 rad), [10] gripper
      pd_ee_delta_pose    [0:3] base velocity, [3:9] TCP delta pose (in the fixed root frame), [9] gripper
    The other control modes change the arm part only (docs/control-modes.md).
    """

    uid = "ml_tidybot"
    urdf_path = urdf_path("ml_tidybot")
    urdf_config = dict(
        _materials=dict(gripper=dict(static_friction=2.0, dynamic_friction=2.0, restitution=0.0)),
        link={f"panda_{f}finger": dict(material="gripper", patch_radius=0.1, min_patch_radius=0.1) for f in ("left", "right")},
    )
    base_joint_names = ["base_x_joint", "base_y_joint", "base_yaw_joint"]
    gripper_joint_names = GRIPPER_JOINTS
    ee_link_name = "panda_hand_tcp"
    # arm folded higher than the fixed Panda's rest (its base is 0.33 m below the table top):
    # TCP 8 cm above the table, 0.47 m ahead of the arm base
    keyframes = dict(rest=rest_keyframe(
        "ml_tidybot", {**dict(zip(ARM_JOINTS, TIDYBOT_ARM_REST)), **{j: GRIPPER_OPEN for j in GRIPPER_JOINTS}}))

    @property
    def _controller_configs(self):
        base = PDBaseVelControllerConfig(
            self.base_joint_names, lower=[-v for v in BASE_MAX_VEL], upper=list(BASE_MAX_VEL),
            damping=BASE_DAMPING, force_limit=BASE_FORCE,
        )
        return combine(base=base, arm=arm_configs(ARM_JOINTS, self.ee_link_name, self.urdf_path), gripper=gripper_config())

    def _after_init(self):
        super()._after_init()
        self.tcp = self.link(self.ee_link_name)
        self.base_link = self.link("base_link")
        self.finger1_link, self.finger2_link = self.link("panda_leftfinger"), self.link("panda_rightfinger")

    @property
    def base_pose(self) -> torch.Tensor:
        """(x, y, yaw) of the base joints, relative to the rest position."""
        return self.robot.get_qpos()[:, :3]
