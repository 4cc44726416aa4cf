"""Procedural controls built as articulations: a spring-loaded push button and a wheel valve.

Both stand on z = 0 with their root link fixed where `set_pose` puts them (a control panel does not
slide), and both read out through their one joint: `button_travel`, `valve_angle`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

# a joint frame whose x axis (the axis of prismatic and revolute joints) points down world -z
DOWN_AXIS = sapien.Pose(q=[np.cos(np.pi / 4), 0, np.sin(np.pi / 4), 0])


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


def _material(color):
    return sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
