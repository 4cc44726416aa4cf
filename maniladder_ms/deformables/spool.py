"""A spool with a rope tied to its drum, as one articulation: a fixed stand, the spool (drum between two flanges)
turning freely on a vertical axle, a crank knob on the top flange turning freely on its own pin (a hand that grips
it circles the axle without turning its wrist), and a rope (`rope.add_rope_links`) whose first capsule is tied to
the drum, lying along the drum's tangent. Turning the spool one way winds the rope onto the drum.

- `coil_turns`: the turns of rope laid on a spool, counted from the tied end (the metric of a coiling task);
- `Spool.lay`: the reset layout (where the spool stands, which way the rope leaves the drum, the rope's shape on
  the table).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sapien
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.deformables import rope
from maniladder_ms.geometry import yaw_quat

# joint frames whose x axis (the axis of revolute joints) points up world z; cylinders lie along their x too
UP_AXIS = sapien.Pose(q=[np.cos(np.pi / 4), 0, -np.sin(np.pi / 4), 0])


@dataclass(frozen=True)
class SpoolShape:
    """A spool on a vertical axle, metres: a stand (a disc of `base_radius`, `base_height` on the table, an axle of
    `axle_radius` up to the spool); the drum (`drum_radius`) runs from `drum_bottom` to `drum_bottom` +
    `drum_length` above the table between two flanges (`flange_radius`, `flange_thickness`); the crank knob
    (`knob_radius`, `knob_height`) stands on the top flange `crank_radius` from the axis. The spool turns against
    `damping` (N m s/rad) and `friction` (N m), so it stays where it is left; the knob turns on its pin against
    `knob_damping`. The rope is tied with its first capsule's axis `tie_clearance` above the bottom flange's top
    plus a rope radius (the first turn lies on the flange)."""

    drum_radius: float = 0.012
    drum_bottom: float = 0.03
    drum_length: float = 0.03
    flange_radius: float = 0.062
    flange_thickness: float = 0.006
    base_radius: float = 0.035
    base_height: float = 0.006
    axle_radius: float = 0.008
    crank_radius: float = 0.045
    knob_radius: float = 0.008
    knob_height: float = 0.04
    damping: float = 0.02
    friction: float = 0.005
    knob_damping: float = 0.001
    tie_clearance: float = 0.002
    color: tuple = (0.55, 0.62, 0.72, 1)
    stand_color: tuple = (0.3, 0.3, 0.34, 1)
    knob_color: tuple = (0.8, 0.15, 0.15, 1)

    @property
    def drum_top(self) -> float:
        return self.drum_bottom + self.drum_length

    @property
    def knob_top(self) -> float:
        """Height of the knob's top above the table."""
        return self.drum_top + self.flange_thickness + self.knob_height


def coil_turns(points: torch.Tensor, axis_xy: torch.Tensor, outer_radius: float, low: float,
               high: float) -> torch.Tensor:
    """Turns of rope laid on a spool, [B]: the winding number (`rope.winding_number`, either sense) about the
    spool's vertical axis through `axis_xy` [B, 2] of the part of the polyline `points` [B, N, 3] (first point: the
    tied end) that runs on the spool from the tied end: its points up to the first one that leaves the spool (more
    than `outer_radius` from the axis, the flanges' rim, or below `low` or above `high`, the heights of its
    flanges' inner faces)."""
    rel = points[..., :2] - axis_xy[:, None, :2]
    on = (torch.linalg.norm(rel, dim=-1) <= outer_radius) & (points[..., 2] >= low) & (points[..., 2] <= high)
    run = torch.cumprod(on.long(), dim=1).bool()  # the points of the unbroken run from the tied end
    angle = torch.atan2(rel[..., 1], rel[..., 0])
    step = torch.remainder(torch.diff(angle, dim=1) + np.pi, 2 * np.pi) - np.pi
    step = torch.where(run[:, 1:], step, torch.zeros_like(step))
    return step.sum(dim=1).abs() / (2 * np.pi)


class Spool:
    """A built spool with its tied rope: `articulation`, `shape`, `rope` (`rope.Rope`: its points, capsule links),
    `knob` (the crank knob's link) and `drum` (the spool's link)."""

    def __init__(self, articulation, shape: SpoolShape, rope_config: rope.RopeConfig, name: str):
        self.articulation = articulation
        self.shape = shape
        self.rope = rope.Rope(articulation, rope_config)
        self.drum = articulation.links_map[f"{name}_drum"]
        self.knob = articulation.links_map[f"{name}_knob"]
        names = [j.name for j in articulation.active_joints]
        self._spin = names.index(f"{name}_spin")
        self._knob_pin = names.index(f"{name}_knob_pin")
        self._bend_z = [names.index(f"bend_z_{i}") for i in range(1, rope_config.segments)]
        self._bend_y = [names.index(f"bend_y_{i}") for i in range(1, rope_config.segments)]

    @property
    def tie_radius(self) -> float:
        """Distance of the tied capsule's axis from the spool axis (drum surface plus a rope radius)."""
        return self.shape.drum_radius + self.rope.config.radius

    @property
    def tie_height(self) -> float:
        return self.shape.drum_bottom + self.rope.config.radius + self.shape.tie_clearance

    @property
    def drop_joint(self) -> int:
        """The joint where the laid rope turns down to the table (`lay`): the first one beyond the flanges' rim
        (with a rope radius to spare) along the drum's tangent."""
        cfg = self.rope.config
        rim = np.sqrt((self.shape.flange_radius + cfg.radius) ** 2 - self.tie_radius ** 2)
        return int(np.ceil((rim - cfg.segment_length / 2) / cfg.segment_length)) + 1

    @property
    def flat_joints(self) -> int:
        """How many in-plane turns `lay` takes: the joints of the rope lying on the table."""
        return self.rope.config.segments - 1 - (self.drop_joint + 2)

    def angle(self) -> torch.Tensor:
        """(B,) the spool's angle (rad, counter-clockwise from above); the rope winds on as it decreases."""
        return self.articulation.get_qpos()[:, self._spin]

    def axis_xy(self) -> torch.Tensor:
        return self.articulation.root.pose.p[:, :2]

    def turns(self) -> torch.Tensor:
        """(B,) turns of rope laid on the drum (`coil_turns`)."""
        s = self.shape
        return coil_turns(self.rope.points(), self.axis_xy(), s.flange_radius, s.drum_bottom, s.drum_top)

    def lay(self, at: torch.Tensor, heading: torch.Tensor, turns: torch.Tensor):
        """Reset layout, at rest: the stand at `at` [b, 2+] on the table; the spool turned so that the rope leaves
        the drum along world yaw `heading` [b] (its first capsule tangent to the drum, on the drum's
        counter-clockwise side); the rope runs level over the bottom flange's rim, down to the table in two
        capsules (from `drop_joint` on), and on over the table curved by the in-plane `turns` [b, `flat_joints`]
        (rad, counter-clockwise, between its capsules from there on)."""
        b = at.shape[0]
        cfg = self.rope.config
        qpos = torch.zeros(b, len(self.articulation.active_joints), device=at.device)
        qpos[:, self._spin] = heading - np.pi / 2  # the tie tangent is +y in the drum's frame
        j = self.drop_joint
        drop = np.arcsin(min(1.0, (self.tie_height - cfg.radius) / (2 * cfg.segment_length)))
        qpos[:, self._bend_y[j - 1]] = drop  # the joint between capsules j - 1 and j tilts the rope down...
        qpos[:, self._bend_y[j + 1]] = -drop  # ...and the one two capsules on levels it again on the table
        qpos[:, self._bend_z[j + 2:]] = turns
        root = torch.cat([at[:, :2], torch.zeros(b, 1, device=at.device)], dim=1)
        self.articulation.set_root_pose(Pose.create_from_pq(root))
        self.articulation.set_qpos(qpos)
        self.articulation.set_qvel(torch.zeros_like(qpos))


def build_spool(scene: ManiSkillScene, name: str, shape: SpoolShape, rope_config: rope.RopeConfig) -> Spool:
    """Build the spool articulation (links `<name>_stand` (fixed root), `<name>_drum`, `<name>_knob` and the rope's;
    joints `<name>_spin`, `<name>_knob_pin` and the rope's bend joints) standing at the origin."""
    s = shape
    render = scene.can_render()

    def material(color):
        return sapien.render.RenderMaterial(base_color=list(color), roughness=0.6)

    def cylinder(link, z: float, radius: float, half: float, color, x: float = 0.0):
        pose = sapien.Pose(p=[x, 0, z]) * UP_AXIS
        link.add_cylinder_collision(pose, radius=radius, half_length=half)
        if render:
            link.add_cylinder_visual(pose, radius=radius, half_length=half, material=material(color))

    builder = scene.create_articulation_builder()
    builder.initial_pose = sapien.Pose()
    stand = builder.create_link_builder()
    stand.set_name(f"{name}_stand")
    cylinder(stand, s.base_height / 2, s.base_radius, s.base_height / 2, s.stand_color)
    axle_low = s.base_height
    axle_high = s.drum_bottom - s.flange_thickness
    cylinder(stand, (axle_low + axle_high) / 2, s.axle_radius, (axle_high - axle_low) / 2, s.stand_color)

    drum = builder.create_link_builder(stand)
    drum.set_name(f"{name}_drum")
    drum.set_joint_name(f"{name}_spin")
    drum.set_joint_properties("revolute", [[-np.inf, np.inf]], UP_AXIS, UP_AXIS, friction=s.friction,
                              damping=s.damping)
    cylinder(drum, s.drum_bottom - s.flange_thickness / 2, s.flange_radius, s.flange_thickness / 2, s.color)
    cylinder(drum, s.drum_bottom + s.drum_length / 2, s.drum_radius, s.drum_length / 2, s.color)
    cylinder(drum, s.drum_top + s.flange_thickness / 2, s.flange_radius, s.flange_thickness / 2, s.color)

    knob = builder.create_link_builder(drum)
    knob.set_name(f"{name}_knob")
    knob.set_joint_name(f"{name}_knob_pin")
    pin = sapien.Pose(p=[s.crank_radius, 0, s.drum_top + s.flange_thickness]) * UP_AXIS
    knob.set_joint_properties("revolute", [[-np.inf, np.inf]], pin, UP_AXIS, damping=s.knob_damping)
    cylinder(knob, s.knob_height / 2, s.knob_radius, s.knob_height / 2, s.knob_color)

    tie_radius = s.drum_radius + rope_config.radius
    tie_height = s.drum_bottom + rope_config.radius + s.tie_clearance
    # the first capsule tangent to the drum at the drum frame's +x, pointing +y (counter-clockwise)
    attach = sapien.Pose(p=[tie_radius, 0, tie_height], q=yaw_quat(torch.tensor([np.pi / 2]))[0].tolist())
    rope.add_rope_links(scene, builder, rope_config, parent=drum, attach=attach)
    articulation = builder.build(name=name, fix_root_link=True)
    rope.configure_rope(articulation, rope_config)
    return Spool(articulation, shape, rope_config, name)
