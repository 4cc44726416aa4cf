"""A bolt with a nut started on its thread, as a ManiSkill articulation built from primitives (ScrewNutOnBolt).

The bolt (root link) stands on its hex head at z = 0, its round shaft pointing up; the nut, a hex ring whose bore
clears the shaft, sits on the shaft's upper end. Two joints carry it: a carriage slides down the shaft on a
prismatic joint (the nut's advance, positive downwards, from where its top face is flush with the bolt's tip) and
the nut turns on the carriage on a revolute joint about the shaft's axis (positive clockwise seen from above, the
way a right-hand nut screws on). `nut_angle` and `nut_advance` read them.

Thread model: the revolute joint is the thread's friction, as the jar's lid (`objects.jar`): a velocity drive to
zero speed, force-limited at `thread_torque` (N m), so the nut stays where it is left and turns only under a
stronger twist, and a bolt that nothing holds turns with it instead. The thread's lead is the coupling of the two
joints: the carriage's drive is a stiff spring whose target `thread_targets` sets before every simulation step
from the nut's angle, `pitch` metres of advance per turn, so the nut visibly runs down the shaft as it is turned
on (and back up as it is turned off). It is the bolt's kinematics, the same whoever turns the nut; nothing holds
the nut but the thread. The revolute joint's lower limit, 0, is the nut's start, one nut height on the thread: it
is not turned off the bolt's end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

from .controls import DOWN_AXIS, X_TO_Z, friction_drive
from .jar import THREAD_DAMPING

# the carriage's spring along the shaft (the thread's lead): stiff against the nut's weight and a gripper's drag
# (a 1 mm lag pushes with 5 N), damped well under its critical damping for the nut's ~10 g
LEAD_STIFFNESS = 5000.0  # N/m
LEAD_DAMPING = 50.0  # N s/m
LEAD_FORCE_LIMIT = 100.0  # N
CARRIAGE_MASS = 0.005  # kg: the carriage has no shape (it is the thread's axial freedom, not a part)
CARRIAGE_INERTIA = 1e-6  # kg m^2 about each axis


@dataclass(frozen=True)
class BoltShape:
    """Sizes (m) and density (kg/m^3) of the bolt and its nut: a hex head `head_across` across its flats and
    `head_height` tall, a round shaft of `shaft_radius` and `shaft_length` on it; a hex nut `nut_across` across
    its flats and `nut_height` tall whose round bore clears the shaft by `bore_clearance`."""

    shaft_radius: float = 0.008
    shaft_length: float = 0.14
    head_across: float = 0.03
    head_height: float = 0.012
    nut_across: float = 0.028
    nut_height: float = 0.014
    bore_clearance: float = 0.001
    density: float = 1200.0  # a nylon bolt: ~0.04 kg, the nut ~0.008 kg

    @property
    def tip_height(self) -> float:
        """Height of the shaft's upper end above the head's bottom face."""
        return self.head_height + self.shaft_length

    @property
    def travel(self) -> float:
        """How far the nut can run down the shaft (to the head)."""
        return self.shaft_length - self.nut_height


def hex_ring_boxes(across: float, height: float, bore: float, z0: float = 0.0):
    """(pose, half size) of six boxes whose union is a hex prism `across` its flats, `height` tall from `z0`
    up, around a round bore of radius `bore` (0: solid): box k lies against the flat whose outward normal is at
    k x 60 degrees about z."""
    apothem = across / 2
    side = across / np.sqrt(3)
    assert bore < apothem, "the bore must leave a wall"
    out = []
    for k in range(6):
        a = np.pi / 3 * k
        r = (apothem + bore) / 2
        pose = sapien.Pose(p=[r * np.cos(a), r * np.sin(a), z0 + height / 2], q=[np.cos(a / 2), 0, 0, np.sin(a / 2)])
        out.append((pose, [(apothem - bore) / 2, side / 2, height / 2]))
    return out


def build_bolt_and_nut(scene: ManiSkillScene, name: str, shape: BoltShape, thread_torque: float, bolt_color,
                       nut_color, marker_color=(0.95, 0.95, 0.95, 1)):
    """The articulation (see the module docstring): links `<name>_bolt` (root), `<name>_carriage`,
    `<name>_nut`; joints `<name>_lead` (prismatic, the advance) and `<name>_thread` (revolute, the turn)."""
    builder = scene.create_articulation_builder()
    bolt = builder.create_link_builder()
    bolt.set_name(f"{name}_bolt")
    bolt_mat = _material(bolt_color)
    for pose, half in hex_ring_boxes(shape.head_across, shape.head_height, 0.0):
        bolt.add_box_collision(pose, half_size=half, density=shape.density)
        bolt.add_box_visual(pose, half_size=half, material=bolt_mat)
    half = shape.shaft_length / 2
    pose = sapien.Pose(p=[0, 0, shape.head_height + half]) * X_TO_Z
    bolt.add_cylinder_collision(pose, radius=shape.shaft_radius, half_length=half, density=shape.density)
    bolt.add_cylinder_visual(pose, radius=shape.shaft_radius, half_length=half, material=bolt_mat)

    carriage = builder.create_link_builder(bolt)
    carriage.set_name(f"{name}_carriage")
    carriage.set_mass_and_inertia(CARRIAGE_MASS, sapien.Pose(), [CARRIAGE_INERTIA] * 3)
    carriage.set_joint_name(f"{name}_lead")
    start = sapien.Pose(p=[0, 0, shape.tip_height - shape.nut_height])  # the nut's bottom face at the start
    carriage.set_joint_properties("prismatic", limits=[[0.0, shape.travel]], pose_in_parent=start * DOWN_AXIS,
                                  pose_in_child=DOWN_AXIS)

    nut = builder.create_link_builder(carriage)
    nut.set_name(f"{name}_nut")
    nut_mat = _material(nut_color)
    for pose, half in hex_ring_boxes(shape.nut_across, shape.nut_height, shape.shaft_radius + shape.bore_clearance):
        nut.add_box_collision(pose, half_size=half, density=shape.density)
        nut.add_box_visual(pose, half_size=half, material=nut_mat)
    # a stripe across the top face, so the nut's turn is visible
    stripe = sapien.Pose(p=[0, 0, shape.nut_height + 0.0005])
    nut.add_box_visual(stripe, half_size=[shape.nut_across / 2 * 0.95, 0.002, 0.0006], material=_material(marker_color))
    nut.set_joint_name(f"{name}_thread")
    nut.set_joint_properties("revolute_unwrapped", limits=[[0.0, np.inf]], pose_in_parent=DOWN_AXIS,
                             pose_in_child=DOWN_AXIS)
    builder.initial_pose = sapien.Pose()
    art = builder.build(name)
    lead, thread = art.active_joints
    lead.set_drive_properties(stiffness=LEAD_STIFFNESS, damping=LEAD_DAMPING, force_limit=LEAD_FORCE_LIMIT)
    lead.set_drive_target(0.0)
    friction_drive(thread, THREAD_DAMPING, thread_torque)
    return art


def nut_angle(art) -> torch.Tensor:
    """(num_envs,) how far (rad) the nut has been turned on, clockwise from above, from its start."""
    return art.get_qpos()[:, 1]


def nut_advance(art) -> torch.Tensor:
    """(num_envs,) how far (m) the nut has run down the shaft from its start."""
    return art.get_qpos()[:, 0]


def thread_targets(art, pitch: float):
    """Set the carriage's target from the nut's angle (`pitch` m per turn): call before every simulation step."""
    art.active_joints[0].set_drive_target(nut_angle(art) * (pitch / (2 * np.pi)))


def _material(color):
    return sapien.render.RenderMaterial(base_color=list(color), roughness=0.4)
