"""A screw-top jar or bottle as a ManiSkill articulation built from primitives (the UnscrewCap family).

The body (root link) is a sealed cylinder standing on z = 0 (optionally with a narrower neck on top, a
bottle); the lid (or cap) sits on its top and turns about the body's axis on a revolute joint, positive
counter-clockwise seen from above (a right-hand thread: the unscrewing direction). `screw_angle` reads it.

Thread model: the joint is the thread. Its lower limit, 0, is the lid screwed home against the rim (it
cannot be tightened further); it turns freely upwards with no upper limit, its angle accumulating over
any number of turns (the joint position is not wrapped), so a lid turned in several strokes, with
regrasps in between, reads the whole turn. The thread's friction is the joint's drive: a velocity drive
to zero speed, stiff in damping but force-limited at `thread_torque` (N m), so the lid stays where it
is left and any torque up to `thread_torque` is resisted as dry (Coulomb) friction would: a lid turns
only under a stronger twist, and a jar that nothing holds spins as a whole instead (its table friction
resists far less). The lid's rise along the thread (a few millimetres over the turns) is not modelled:
a task decides from the angle when the lid is off its thread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

from .controls import UP_AXIS, X_TO_Z, friction_drive

# the drive that models the thread's friction: damping far above what a moving lid reaches, so that the
# torque it asks saturates at the force limit (the thread torque) as soon as the lid turns at all
THREAD_DAMPING = 50.0  # N m s / rad
LID_MARKERS = 2  # white stripes across the lid's top, so its turn is visible


@dataclass(frozen=True)
class JarShape:
    """Sizes (m) and densities (kg/m^3) of a screw-top container: a body cylinder of `body_radius` and
    `body_height`, a neck of `neck_radius` and `neck_height` on top (0: none, a jar), and a lid of
    `lid_radius` and `lid_height` on top of that."""

    body_radius: float = 0.03
    body_height: float = 0.11
    lid_radius: float = 0.033
    lid_height: float = 0.022
    neck_radius: float = 0.0
    neck_height: float = 0.0
    body_density: float = 1300.0  # a filled glass jar: ~0.4 kg at the default size
    lid_density: float = 500.0

    @property
    def rim_height(self) -> float:
        """Height of the lid's bottom face (the top of the body or neck) above the jar's base."""
        return self.body_height + self.neck_height

    @property
    def height(self) -> float:
        return self.rim_height + self.lid_height


def build_screw_jar(scene: ManiSkillScene, name: str, shape: JarShape, thread_torque: float, body_color,
                    lid_color, marker_color=(0.95, 0.95, 0.95, 1), fixed: bool = False):
    """The jar articulation: the body (root; `fixed`: clamped where `set_pose` puts it) and the lid on the
    thread joint (see the module docstring). Links `<name>_body`, `<name>_lid`."""
    builder = scene.create_articulation_builder()
    body = builder.create_link_builder()
    body.set_name(f"{name}_body")
    body_mat = _material(body_color)
    half = shape.body_height / 2
    pose = sapien.Pose(p=[0, 0, half]) * X_TO_Z
    body.add_cylinder_collision(pose, radius=shape.body_radius, half_length=half, density=shape.body_density)
    body.add_cylinder_visual(pose, radius=shape.body_radius, half_length=half, material=body_mat)
    if shape.neck_height > 0:
        half = shape.neck_height / 2
        pose = sapien.Pose(p=[0, 0, shape.body_height + half]) * X_TO_Z
        body.add_cylinder_collision(pose, radius=shape.neck_radius, half_length=half, density=shape.body_density)
        body.add_cylinder_visual(pose, radius=shape.neck_radius, half_length=half, material=body_mat)

    lid = builder.create_link_builder(body)
    lid.set_name(f"{name}_lid")
    half = shape.lid_height / 2
    pose = sapien.Pose(p=[0, 0, half]) * X_TO_Z  # lid frame: origin on the rim, on the axis
    lid.add_cylinder_collision(pose, radius=shape.lid_radius, half_length=half, density=shape.lid_density)
    lid.add_cylinder_visual(pose, radius=shape.lid_radius, half_length=half, material=_material(lid_color))
    marker_mat = _material(marker_color)
    for k in range(LID_MARKERS):
        a = np.pi * k / LID_MARKERS
        stripe = sapien.Pose(p=[0, 0, shape.lid_height + 0.0005], q=[np.cos(a / 2), 0, 0, np.sin(a / 2)])
        lid.add_box_visual(stripe, half_size=[shape.lid_radius * 0.9, 0.003, 0.0006], material=marker_mat)
    lid.set_joint_name(f"{name}_thread")
    lid.set_joint_properties("revolute_unwrapped", limits=[[0.0, np.inf]],
                             pose_in_parent=sapien.Pose(p=[0, 0, shape.rim_height]) * UP_AXIS,
                             pose_in_child=UP_AXIS)
    builder.initial_pose = sapien.Pose()
    jar = builder.build(name, fix_root_link=fixed)
    friction_drive(jar.active_joints[0], THREAD_DAMPING, thread_torque)
    return jar


def screw_angle(jar) -> torch.Tensor:
    """(num_envs,) how far (rad) the lid is unscrewed: its thread joint's angle, counter-clockwise from
    above, accumulated over turns."""
    return jar.get_qpos()[:, 0]


def _material(color):
    return sapien.render.RenderMaterial(base_color=list(color), roughness=0.4)
