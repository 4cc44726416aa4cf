"""Procedural controls built as articulations: a spring-loaded push button and a wheel valve, and a
curved arrow that marks which way to turn.

Button and valve stand on z = 0 with their root link fixed where `set_pose` puts them (a control panel
does not slide), and read out through their one joint: `button_travel`, `valve_angle`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

# joint frames whose x axis (the axis of prismatic and revolute joints) points down / up world z
DOWN_AXIS = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])
UP_AXIS = sapien.Pose(q=[np.cos(np.pi / 4), 0, -np.sin(np.pi / 4), 0])
# turns a capsule or cylinder (their axis is their local x) upright
X_TO_Z = UP_AXIS


def friction_drive(joint, damping: float, force_limit: float):
    """Make `joint` hold still under loads below `force_limit` and give way above it: a velocity drive to zero with
    no stiffness, its force limit the joint's friction (a screw thread, a peg tight in its hole)."""
    joint.set_drive_properties(stiffness=0.0, damping=damping, force_limit=force_limit)
    joint.set_drive_velocity_target(0.0)

@dataclass(frozen=True)
class ButtonShape:
    """A round push button (cap) in a square housing, metres / N/m.

    The cap rises `protrusion` above the housing top and goes down by up to `travel`. A spring (the
    joint's drive, `stiffness`) pushes it back up; its rest point lies `preload` above the top stop, so
    the cap rests against the stop instead of sagging under its own weight.
    """

    housing_half: float = 0.045
    housing_height: float = 0.03
    cap_radius: float = 0.025
    cap_height: float = 0.025
    protrusion: float = 0.018
    travel: float = 0.012
    stiffness: float = 400.0
    damping: float = 5.0
    preload: float = 0.005

    @property
    def cap_top(self) -> float:
        """Height of the cap's top face above the table when released."""
        return self.housing_height + self.protrusion


def build_push_button(scene: ManiSkillScene, name: str, shape: ButtonShape, housing_color, cap_color):
    """The button articulation: fixed housing (root) and the cap on a prismatic joint, pressed = positive."""
    builder = scene.create_articulation_builder()
    housing = builder.create_link_builder()
    housing.set_name(f"{name}_housing")
    half = [shape.housing_half, shape.housing_half, shape.housing_height / 2]
    housing.add_box_collision(sapien.Pose(p=[0, 0, shape.housing_height / 2]), half_size=half)
    housing.add_box_visual(sapien.Pose(p=[0, 0, shape.housing_height / 2]),
                           half_size=half, material=_material(housing_color))
    cap = builder.create_link_builder(housing)
    cap.set_name(f"{name}_cap")
    # cap frame: origin on the housing top, x down (the joint axis); the cylinder's axis is its local x
    cap_centre = sapien.Pose(p=[shape.cap_height / 2 - shape.protrusion, 0, 0])
    cap.add_cylinder_collision(cap_centre, radius=shape.cap_radius, half_length=shape.cap_height / 2)
    cap.add_cylinder_visual(cap_centre, radius=shape.cap_radius, half_length=shape.cap_height / 2,
                            material=_material(cap_color))
    cap.set_joint_name(f"{name}_press")
    cap.set_joint_properties("prismatic", limits=[[0.0, shape.travel]],
                             pose_in_parent=sapien.Pose(p=[0, 0, shape.housing_height]) * DOWN_AXIS,
                             pose_in_child=sapien.Pose())
    builder.initial_pose = sapien.Pose()
    button = builder.build(name, fix_root_link=True)
    joint = button.active_joints[0]
    joint.set_drive_properties(stiffness=shape.stiffness, damping=shape.damping)
    joint.set_drive_target(-shape.preload)
    return button


def button_travel(button) -> torch.Tensor:
    """(num_envs,) how far (m) the cap is pressed down."""
    return button.get_qpos()[:, 0]


@dataclass(frozen=True)
class ValveShape:
    """A hand wheel on a vertical stem, metres: `spokes` spokes from the hub to a rim of `radius` (the rim
    tube's centre line), the wheel's centre `height` above the table. The joint turns freely (no
    limits) against `damping` (N m s/rad), so the wheel stays where it is left."""

    height: float = 0.1
    radius: float = 0.085
    rim_thickness: float = 0.008  # tube radius
    spokes: int = 4
    spoke_radius: float = 0.006
    hub_radius: float = 0.015
    stem_radius: float = 0.012
    base_radius: float = 0.05
    base_height: float = 0.015
    damping: float = 0.1
    rim_segments: int = 16


def build_wheel_valve(scene: ManiSkillScene, name: str, shape: ValveShape, stand_color, wheel_color, marker_color):
    """The valve articulation: fixed stand (root) and the wheel on a revolute joint about +z (positive
    angle: counter-clockwise seen from above). Spoke 0 (along the wheel's x axis) is `marker_color`."""
    builder = scene.create_articulation_builder()
    stand = builder.create_link_builder()
    stand.set_name(f"{name}_stand")
    stand_mat = _material(stand_color)
    base = sapien.Pose(p=[0, 0, shape.base_height / 2]) * X_TO_Z
    stand.add_cylinder_collision(base, radius=shape.base_radius, half_length=shape.base_height / 2)
    stand.add_cylinder_visual(base, radius=shape.base_radius, half_length=shape.base_height / 2, material=stand_mat)
    stem_half = (shape.height - shape.base_height) / 2
    stem = sapien.Pose(p=[0, 0, shape.base_height + stem_half]) * X_TO_Z
    stand.add_cylinder_collision(stem, radius=shape.stem_radius, half_length=stem_half)
    stand.add_cylinder_visual(stem, radius=shape.stem_radius, half_length=stem_half, material=stand_mat)

    wheel = builder.create_link_builder(stand)
    wheel.set_name(f"{name}_wheel")
    wheel_mat, marker_mat = _material(wheel_color), _material(marker_color)
    hub = X_TO_Z
    wheel.add_cylinder_collision(hub, radius=shape.hub_radius, half_length=shape.spoke_radius * 1.5)
    wheel.add_cylinder_visual(hub, radius=shape.hub_radius, half_length=shape.spoke_radius * 1.5, material=wheel_mat)
    seg = 2 * np.pi / shape.rim_segments
    for k in range(shape.rim_segments):  # the rim: tangent capsules around the circle
        a = (k + 0.5) * seg
        pose = sapien.Pose(p=[shape.radius * np.cos(a), shape.radius * np.sin(a), 0], q=_yaw(a + np.pi / 2))
        half = shape.radius * np.sin(seg / 2)
        wheel.add_capsule_collision(pose, radius=shape.rim_thickness, half_length=half)
        wheel.add_capsule_visual(pose, radius=shape.rim_thickness, half_length=half, material=wheel_mat)
    spoke_half = (shape.radius - shape.hub_radius) / 2
    for k in range(shape.spokes):
        a = 2 * np.pi * k / shape.spokes
        mid = shape.hub_radius + spoke_half
        pose = sapien.Pose(p=[mid * np.cos(a), mid * np.sin(a), 0], q=_yaw(a))
        wheel.add_capsule_collision(pose, radius=shape.spoke_radius, half_length=spoke_half)
        wheel.add_capsule_visual(pose, radius=shape.spoke_radius, half_length=spoke_half,
                                 material=marker_mat if k == 0 else wheel_mat)
    wheel.set_joint_name(f"{name}_turn")
    wheel.set_joint_properties("revolute", limits=[[-np.inf, np.inf]],
                               pose_in_parent=sapien.Pose(p=[0, 0, shape.height]) * UP_AXIS, pose_in_child=UP_AXIS,
                               damping=shape.damping)
    builder.initial_pose = sapien.Pose()
    return builder.build(name, fix_root_link=True)


def valve_angle(valve) -> torch.Tensor:
    """(num_envs,) the wheel's angle (rad, counter-clockwise from above) from where it was built."""
    return valve.get_qpos()[:, 0]


def build_turn_arrow(scene: ManiSkillScene, name: str, radius: float, color, span: float = np.pi / 2,
                     width: float = 0.014, head: float = 0.025):
    """A flat curved arrow (visual only, kinematic) lying on an arc of `radius` around its origin, from
    -span/2 to +span/2 about its x axis, its head pointing counter-clockwise (seen from above, local z up).

    Turned upside down (by pi about its x axis) it points clockwise: `turn_direction` reads which.
    """
    builder = scene.create_actor_builder()
    mat = _material(color)
    pieces = 8
    step = span / pieces
    half_thick = 0.001
    for k in range(pieces):  # the shaft: short tangent boxes along the arc
        a = -span / 2 + (k + 0.5) * step
        pose = sapien.Pose(p=[radius * np.cos(a), radius * np.sin(a), 0], q=_yaw(a + np.pi / 2))
        builder.add_box_visual(pose, half_size=[radius * np.sin(step / 2) * 1.1, width / 2, half_thick], material=mat)
    tip_angle = span / 2 + 0.6 * head / radius
    tip = np.array([radius * np.cos(tip_angle), radius * np.sin(tip_angle)])
    for side in (1, -1):  # the head: two strokes `head` long back from the tip, 35 degrees off the tangent
        back = np.pi / 2 + tip_angle + np.pi + side * np.radians(35)
        centre = tip + head / 2 * np.array([np.cos(back), np.sin(back)])
        builder.add_box_visual(sapien.Pose(p=[*centre, 0], q=_yaw(back)), half_size=[head / 2, width / 2, half_thick],
                               material=mat)
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name)


def turn_direction(arrow) -> torch.Tensor:
    """(num_envs,) +1 where the arrow points counter-clockwise (lies face up), -1 where it points clockwise."""
    q = arrow.pose.q  # the arrow's z axis, world z component: 1 - 2 (qx^2 + qy^2)
    return torch.where(1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2) > 0, 1.0, -1.0)


def _yaw(a: float) -> list[float]:
    return [np.cos(a / 2), 0, 0, np.sin(a / 2)]


def _material(color):
    return sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
