"""Visual-only goal markers: flat tiles on the table that objects pass through."""

from __future__ import annotations

import sapien

from mani_skill.envs.scene import ManiSkillScene
from mani_skill.utils.building import actors

MARKER_THICKNESS = 0.002


def build_zone_marker(scene: ManiSkillScene, name: str, half_size, color) -> "Actor":
    """A flat tile marking a target zone: square (side 2 * `half_size`) or, with `half_size` (x, y), a
    rectangle; kinematic, no collision shape. Its origin is its centre, so it lies on the table at
    z = MARKER_THICKNESS / 2."""
    hx, hy = (half_size, half_size) if isinstance(half_size, (int, float)) else half_size
    return actors.build_box(scene, [hx, hy, MARKER_THICKNESS / 2], color, name, body_type="kinematic",
                            add_collision=False, initial_pose=sapien.Pose(p=[0, 0, MARKER_THICKNESS / 2]))
