"""A keyed plug and its socket, built from boxes (PlugUSB).

The plug stands along its local z: a connector (a box `2 * tongue_half` wide along x, `2 * shell_half_y` thick
along y, `connector_length` long) with a key rib along its +y face (`2 * key_half_width` wide, `key_depth`
proud, as long as the connector), under a housing the gripper holds. Its origin is the centre of the
connector's lower end (the tip), so a plug standing on its tip has its origin on the table.

The socket is a fixture block standing on z = 0, its origin at the centre of its bottom face, its z axis the
slot's axis: a base plate, then walls around a slot that takes the connector with `clearance` of play in all
(half on each side), with a groove for the rib on its +y side only. A plug turned half a turn about its axis
brings its rib over the slot's -y wall: pushed as far +y as the slot lets it, the rib still overlaps that
wall by `key_depth - clearance`, so it cannot go in.
"""

from __future__ import annotations

from dataclasses import dataclass

import sapien
import sapien.render

from mani_skill.envs.scene import ManiSkillScene

PLASTIC_DENSITY = 1100.0


@dataclass(frozen=True)
class USBShape:
    shell_half_x: float = 0.006  # the connector's half width (12 mm wide)
    shell_half_y: float = 0.0025  # its half thickness (5 mm)
    connector_length: float = 0.012
    key_half_width: float = 0.0015  # the rib's half width along x (3 mm wide)
    key_depth: float = 0.002  # how far the rib stands proud of the connector's +y face
    housing_half: tuple = (0.009, 0.0055, 0.015)  # the housing's half sizes (18 x 11 x 30 mm)
    clearance: float = 0.001  # the slot's play: its width minus the connector's, on both axes
    slot_depth: float = 0.014  # from the socket's top face down to the slot's floor
    socket_half: tuple = (0.022, 0.016)  # the socket block's half footprint
    socket_base: float = 0.01  # the floor under the slot

    @property
    def length(self) -> float:
        """The plug's length, tip to the housing's top."""
        return self.connector_length + 2 * self.housing_half[2]

    @property
    def socket_top(self) -> float:
        return self.socket_base + self.slot_depth

    @property
    def slot_half(self) -> tuple[float, float]:
        return self.shell_half_x + self.clearance / 2, self.shell_half_y + self.clearance / 2

    def plug_parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) boxes in the plug frame: connector, key rib, housing."""
        lc, hx, hy = self.connector_length, self.shell_half_x, self.shell_half_y
        hh = self.housing_half
        return [
            ([0, 0, lc / 2], [hx, hy, lc / 2]),
            ([0, hy + self.key_depth / 2, lc / 2], [self.key_half_width, self.key_depth / 2, lc / 2]),
            ([0, 0, lc + hh[2]], list(hh)),
        ]

    def socket_parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) boxes in the socket frame: the base plate, the walls at +-x, the wall at -y, and
        on the +y side the two wall pieces beside the groove and the piece behind it."""
        (sx, sy), (W, H) = self.slot_half, self.socket_half
        gx = self.key_half_width + self.clearance / 2  # the groove's half width
        gy = sy + self.key_depth  # the groove's far side (the rib's face plus half the clearance)
        z0, z1 = self.socket_base, self.socket_top
        zc, zh = (z0 + z1) / 2, (z1 - z0) / 2
        return [
            ([0, 0, z0 / 2], [W, H, z0 / 2]),
            ([(sx + W) / 2, 0, zc], [(W - sx) / 2, H, zh]),
            ([-(sx + W) / 2, 0, zc], [(W - sx) / 2, H, zh]),
            ([0, -(sy + H) / 2, zc], [sx, (H - sy) / 2, zh]),
            ([(gx + sx) / 2, (sy + H) / 2, zc], [(sx - gx) / 2, (H - sy) / 2, zh]),
            ([-(gx + sx) / 2, (sy + H) / 2, zc], [(sx - gx) / 2, (H - sy) / 2, zh]),
            ([0, (gy + H) / 2, zc], [gx, (H - gy) / 2, zh]),
        ]


def _material(color):
    return sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)


def build_usb_plug(scene: ManiSkillScene, name: str, shape: USBShape, housing_color, shell_color=(0.75, 0.75, 0.78, 1),
                   key_color=(0.15, 0.15, 0.15, 1)) -> "Actor":
    """The plug (see the module docstring): a metal-grey connector, its rib dark (the key shows), a housing
    in `housing_color` with a cable stub on top."""
    builder = scene.create_actor_builder()
    connector, rib, housing = shape.plug_parts()
    for (centre, half), color in ((connector, shell_color), (rib, key_color), (housing, housing_color)):
        builder.add_box_collision(pose=sapien.Pose(p=centre), half_size=half, density=PLASTIC_DENSITY)
        builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half, material=_material(color))
    # a mark on the housing's +y face, on the rib's side (which way round the plug is, as a USB logo shows)
    hh = shape.housing_half
    builder.add_box_visual(pose=sapien.Pose(p=[0, hh[1] + 0.0003, shape.connector_length + hh[2]]),
                           half_size=[0.004, 0.0003, 0.006], material=_material(key_color))
    builder.add_cylinder_visual(pose=sapien.Pose(p=[0, 0, shape.length + 0.006], q=[0.7071068, 0, 0.7071068, 0]),
                                radius=0.003, half_length=0.006, material=_material((0.1, 0.1, 0.1, 1)))
    builder.initial_pose = sapien.Pose()
    return builder.build(name=name)


def build_usb_socket(scene: ManiSkillScene, name: str, shape: USBShape, color, groove_color=(0.15, 0.15, 0.15, 1)) -> "Actor":
    """The socket block (see the module docstring), a fixture (kinematic); a dark band on its top face beside
    the groove marks which way round the plug goes."""
    builder = scene.create_actor_builder()
    for centre, half in shape.socket_parts():
        builder.add_box_collision(pose=sapien.Pose(p=centre), half_size=half)
        builder.add_box_visual(pose=sapien.Pose(p=centre), half_size=half, material=_material(color))
    sy, H = shape.slot_half[1] + shape.key_depth, shape.socket_half[1]
    builder.add_box_visual(pose=sapien.Pose(p=[0, (sy + H) / 2, shape.socket_top + 0.0003]),
                           half_size=[0.004, (H - sy) / 2 - 0.001, 0.0003], material=_material(groove_color))
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)
