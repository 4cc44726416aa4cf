"""The U-shaped cable clip of the clip tasks (CableIntoClipHand's one clip, RouteCableClipsHand's row of three): a
`tabletop.Channel` with a 4 mm base plate and two 8 mm thick walls, fixed to the table; a capsule is inside its
slot when `Channel.inside_fraction` counts it (between the walls and the ends, below the walls' top)."""

from __future__ import annotations

from mani_skill.envs.scene import ManiSkillScene

from maniladder_ms.objects.tabletop import Channel

CLIP_WALL = 0.008  # thickness of each of the clip's two walls
CLIP_FLOOR = 0.004  # the clip's base plate: the slot's floor lies this high above the table
CLIP_COLOR, CLIP_FLOOR_COLOR = (0.15, 0.35, 0.75, 1), (0.1, 0.2, 0.45, 1)


def build_clip(scene: ManiSkillScene, name: str, slot_width: float, depth: float, length: float,
               color=CLIP_COLOR, floor_color=CLIP_FLOOR_COLOR) -> Channel:
    """A clip `name` on the table: its slot `slot_width` wide, walls `depth` above the slot's floor, `length`
    long, open at both ends (a `Channel` along its local x axis, origin on the table under the slot's middle)."""
    return Channel(scene, name, slot_width, depth, length, CLIP_WALL, CLIP_FLOOR, color, floor_color)
