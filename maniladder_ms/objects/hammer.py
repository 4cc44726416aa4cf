"""A hammer and a peg board built from boxes (HammerPeg).

Hammer: a handle along the tool's local +x and, at its +x end, a block head standing up from it; the handle's
and the head's bottom faces are flush, so the hammer lies flat on the table and its striking face is the
head's bottom face. The origin lies on the handle's bottom face, under the handle's centre.

Peg board: an articulation. The root link is the board, a block standing on z = 0 with a square hole through its
middle (four boxes round the hole); the peg, a square bar, is a child link on a prismatic joint along the hole's
axis, positive down (how far the peg has been driven from its highest position). The joint's drive models the
peg's friction in the hole: a velocity drive to zero speed whose damping is far above what a moving peg reaches
and whose force is limited to `hold_force` (N), so a steady push up to `hold_force` is resisted as dry (Coulomb)
friction would (the peg creeps at most push / `PEG_DAMPING` m/s), while a blow whose force over a physics step
exceeds it drives the peg in by a step. Its lower limit is the peg's top `rise` above the board's top face, its
upper limit the peg's top flush with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.envs.scene import ManiSkillScene

from .controls import DOWN_AXIS, friction_drive
from .tabletop import WOOD_DENSITY

STEEL_DENSITY = 7800.0  # kg/m^3
# the drive that models the peg's friction: damping so high that the force it asks saturates at the force
# limit as soon as the peg moves at all (a push just under an 18 N limit creeps at 0.02 mm/s; N s/m)
PEG_DAMPING = 1.0e6


@dataclass(frozen=True)
class HammerShape:
    """A `handle_length` long handle (`handle_width` wide, `handle_height` high) and a head
    (`head_length` along the handle, `head_width` across it, `head_height` high) at its +x end."""

    handle_length: float = 0.24
    handle_width: float = 0.022
    handle_height: float = 0.024
    head_length: float = 0.03
    head_width: float = 0.03
    head_height: float = 0.05

    def parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) of the handle, then the head, in the tool frame."""
        handle = ([0.0, 0.0, self.handle_height / 2], [self.handle_length / 2, self.handle_width / 2,
                                                      self.handle_height / 2])
        head = ([self.head_x, 0.0, self.head_height / 2], [self.head_length / 2, self.head_width / 2,
                                                          self.head_height / 2])
        return [handle, head]

    @property
    def head_x(self) -> float:
        """Local x of the head's centre (the head ends flush with the handle's +x end)."""
        return self.handle_length / 2 - self.head_length / 2


def build_hammer(scene: ManiSkillScene, name: str, shape: HammerShape, handle_color, head_color,
                 head_density: float = STEEL_DENSITY, handle_density: float = WOOD_DENSITY) -> "Actor":
    """The hammer as a dynamic actor lying flat (see the module docstring)."""
    builder = scene.create_actor_builder()
    (handle_c, handle_h), (head_c, head_h) = shape.parts()
    builder.add_box_collision(sapien.Pose(p=handle_c), half_size=handle_h, density=handle_density)
    builder.add_box_visual(sapien.Pose(p=handle_c), half_size=handle_h,
                           material=sapien.render.RenderMaterial(base_color=list(handle_color), roughness=0.6))
    builder.add_box_collision(sapien.Pose(p=head_c), half_size=head_h, density=head_density)
    builder.add_box_visual(sapien.Pose(p=head_c), half_size=head_h,
                           material=sapien.render.RenderMaterial(base_color=list(head_color), roughness=0.3,
                                                                 metallic=0.8))
    builder.initial_pose = sapien.Pose()
    return builder.build(name=name)


@dataclass(frozen=True)
class PegBoardShape:
    """The board: `board_half` x `board_half` (half sides), `board_height` high, a square hole of half side
    `peg_half` + `clearance` / 2 through it; the peg: `peg_half` square, `peg_length` long, its top at most
    `rise` above the board's top face."""

    peg_half: float
    rise: float = 0.045
    peg_length: float = 0.048
    clearance: float = 0.002
    board_half: float = 0.045
    board_height: float = 0.05

    @property
    def hole_half(self) -> float:
        return self.peg_half + self.clearance / 2

    def board_parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) of the four boxes round the hole, in the board frame (origin: the hole's axis
        on the table)."""
        h, o, z = self.hole_half, self.board_half, self.board_height / 2
        side = (o - h) / 2
        return [([h + side, 0, z], [side, o, z]), ([-h - side, 0, z], [side, o, z]),
                ([0, h + side, z], [h, side, z]), ([0, -h - side, z], [h, side, z])]


def build_peg_board(scene: ManiSkillScene, name: str, shape: PegBoardShape, hold_force: float, board_color,
                    peg_color, top_color):
    """The board articulation (see the module docstring): links `<name>_board` (root, fixed where `set_pose`
    puts it) and `<name>_peg` (its top face marked in `top_color`), joint `<name>_drive`."""
    builder = scene.create_articulation_builder()
    board = builder.create_link_builder()
    board.set_name(f"{name}_board")
    board_mat = sapien.render.RenderMaterial(base_color=list(board_color), roughness=0.7)
    for centre, half in shape.board_parts():
        board.add_box_collision(sapien.Pose(p=centre), half_size=half, density=WOOD_DENSITY)
        board.add_box_visual(sapien.Pose(p=centre), half_size=half, material=board_mat)
    peg = builder.create_link_builder(board)
    peg.set_name(f"{name}_peg")
    # peg frame: origin at the centre of the peg's top face, x down (the joint axis)
    p, length = shape.peg_half, shape.peg_length
    peg.add_box_collision(sapien.Pose(p=[length / 2, 0, 0]), half_size=[length / 2, p, p], density=WOOD_DENSITY)
    peg.add_box_visual(sapien.Pose(p=[length / 2 + 0.001, 0, 0]), half_size=[length / 2 - 0.001, p, p],
                       material=sapien.render.RenderMaterial(base_color=list(peg_color), roughness=0.6))
    peg.add_box_visual(sapien.Pose(p=[0.001, 0, 0]), half_size=[0.001, p * 1.001, p * 1.001],
                       material=sapien.render.RenderMaterial(base_color=list(top_color), roughness=0.6))
    peg.set_joint_name(f"{name}_drive")
    peg.set_joint_properties("prismatic", limits=[[0.0, shape.rise]],
                             pose_in_parent=sapien.Pose(p=[0, 0, shape.board_height + shape.rise]) * DOWN_AXIS,
                             pose_in_child=sapien.Pose())
    builder.initial_pose = sapien.Pose()
    art = builder.build(name, fix_root_link=True)
    friction_drive(art.active_joints[0], PEG_DAMPING, hold_force)
    return art


def peg_driven(board) -> torch.Tensor:
    """(num_envs,) how far (m) the peg has been driven down from its highest position."""
    return board.get_qpos()[:, 0]
