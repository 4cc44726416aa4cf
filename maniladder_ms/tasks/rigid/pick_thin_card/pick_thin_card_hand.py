"""PickThinCardHand (L3 rigid SX, family PickThinCard): pick a thin card lying flat on the table, tilting it up a block
first."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import leap_fingertip
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import tilt, yaw_quat

from .base import PickThinCardTask

# the block: a slab pitched so that its top face is a ramp rising from the table, away from the robot, to an edge
# `block_height` above the table (the slab's lower part lies inside the table)
BLOCK_HALF = (0.08, 0.15, 0.01)  # the slab: 16 cm along the slope, 30 cm wide (y), 2 cm thick
# the ramp's angle to the table: steep enough that the ramp (7.8 cm long at a 5 cm edge) is shorter than the card's
# part behind the edge, so the card rests on the edge with its rear end on the table (at 30 degrees the card lay on
# the ramp's face, its rear end lifted, and slid 2 cm back down when the finger let go)
BLOCK_SLOPE = np.deg2rad(40)
BLOCK_FRICTION = 0.3  # the ramp: low enough for the card's front edge to ride up it (1.0 jammed it at the foot)
# the ramp's top edge is a rubber nose (a cylinder along y of the slab's half thickness, tangent to the ramp's face
# and to the slab's far face, so the ramp's face rises to 4 mm below `block_height`): the card comes to rest tilted
# ~33 degrees across it, its weight pushing it back along itself, and on the ramp's own surface (averaged friction
# 0.3) it slid back down; a rubber rod standing proud of the edge, a flush 3 cm rubber box of friction 1.5, and on
# 6 of the 10 failures among seeds 100-149 a flush 1 cm rubber box of friction 1.0, stalled the climbing card's front
# edge at the box's start (a deeper press did not move it); over the round nose every one of those climbed (a nose
# of friction 2.0 stalled it again; a 4 mm radius let the card slide further back once the finger let go)
PAD_FRICTION = 1.0
NOSE_RADIUS = BLOCK_HALF[2]
TILTED = np.deg2rad(10)  # the card counts as tilted up (an intermediate flag) past this angle


def build_block(scene):
    """The block (kinematic; origin at the slab's centre, unpitched): the slab, its top far edge (local +x) a rubber
    nose (a cylinder along y, NOSE_RADIUS) tangent to its top and far faces."""
    builder = scene.create_actor_builder()
    a, w, c = BLOCK_HALF
    nose = a - NOSE_RADIUS
    slab = sapien.Pose(p=[(nose - a) / 2, 0.0, 0.0])
    along_y = sapien.Pose(p=[nose, 0.0, c - NOSE_RADIUS], q=[np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    builder.add_box_collision(pose=slab, half_size=[(nose + a) / 2, w, c],
                              material=physx.PhysxMaterial(BLOCK_FRICTION, BLOCK_FRICTION, 0.0))
    builder.add_cylinder_collision(pose=along_y, radius=NOSE_RADIUS, half_length=w,
                                   material=physx.PhysxMaterial(PAD_FRICTION, PAD_FRICTION, 0.0))
    if scene.can_render():
        builder.add_box_visual(pose=slab, half_size=[(nose + a) / 2, w, c],
                               material=sapien.render.RenderMaterial(base_color=[0.55, 0.4, 0.25, 1], roughness=0.6))
        builder.add_cylinder_visual(pose=along_y, radius=NOSE_RADIUS, half_length=w,
                                    material=sapien.render.RenderMaterial(base_color=[0.12, 0.12, 0.12, 1],
                                                                          roughness=0.6))
    builder.initial_pose = sapien.Pose(p=[0, 0, c])
    return builder.build_kinematic(name="block")


@register_task("PickThinCardHand")
class PickThinCardHandEnv(PickThinCardTask):
    """**Task:** a thin plastic card lies flat on the table, too thin for any finger to get under it. A block
    stands ahead of it (away from the robot), its near face a ramp rising from the table towards an edge
    `block_height` up (the edge rounded: a rubber nose, its top 4 mm lower). Press the card with a fingertip and
    slide it into the block so that its far end rides up the ramp and out over the block's edge, tilting the card up
    off the table; then take its raised end in the hand and lift the card.

    **Randomisation:** the card (`card_length` x `card_width` x `card_thickness`, ~14 g) lies with its centre
    uniform in x in [-0.27, -0.21] (`CARD_X`) and y in [-0.08, 0.08] (`CARD_Y`), yawed uniform in [-15, 15]
    degrees (`CARD_YAW`); the block (a 30 cm wide ramp at `BLOCK_SLOPE` to the table, its top edge a
    rubber nose rounded with the slab's half thickness, `NOSE_RADIUS`) stands square to the robot with the foot of
    its ramp 1.5-3.5 cm (uniform, `BLOCK_GAP`) beyond the card's far end, its centre's y within +-4 cm (`BLOCK_Y`)
    of the card's.

    **Success:** (the PickThinCard family rule, `PickThinCardTask`) the card's lowest point is at least
    `lift_height` above the table, higher than the block's edge (`block_height`), and the hand holds it
    (`ee.holds`: a finger pressing against the thumb or palm, or the index / middle scissor pinch).

    **Level 3:** against Level 2's SlideCardToEdgeHand (the card on a stand, slid 7-11 cm on the flat to a
    3-5 cm overhang with 8 cm of free space under it, clamped flat with a top-down hand, 4 stages, ~120 steps):
    there is no edge to slide the card over, only the table, so the card must first be made to stand off it with a
    tool the scene offers. The fingertip pressing the card 2 mm into it 2 cm from its rear end slides it 12-16 cm,
    its far end up a 40-degree ramp and 3.5 cm out over an edge 5 cm up, the press following the card's top as it
    tilts (a fixed press slipped up the card; a push along the tilted card lifted its rear end, and the card slid
    back); the card then rests tilted ~33 degrees, and the clamp must be made in the card's tilted frame (the hand
    pitched ~33 degrees, its palm on the raised end, the index and middle fingers swung up under the 2-3 cm
    of card between the block's edge and the end), and the lift must raise the card's lowest point 5 cm clear of the
    table with the card hanging ~45 degrees from the clamp; 5 stages (press, slide up the ramp and over the edge,
    let go without the card sliding back, clamp the tilted end, lift), ~200 steps.
    """

    max_dense_reward = 6
    TASK_REGION = (-0.4, 0.0, -0.25, 0.25)
    PARAMS = PickThinCardTask.PARAMS + ("block_height",)
    # layout ranges: (low, span), or the half width of a range centred on 0
    CARD_X = (-0.27, 0.06)
    CARD_Y = 0.08
    CARD_YAW = 15  # degrees
    BLOCK_GAP = (0.015, 0.02)  # the ramp's foot beyond the card's far end
    BLOCK_Y = 0.04  # the block's centre from the card's

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.block = build_block(self.scene)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            x = self.CARD_X[0] + torch.rand(b) * self.CARD_X[1]
            y = (torch.rand(b) * 2 - 1) * self.CARD_Y
            card = torch.stack([x, y, torch.full((b,), self.card_thickness / 2)], dim=1)
            yaw = (torch.rand(b) * 2 - 1) * np.deg2rad(self.CARD_YAW)
            self.card.set_pose(Pose.create_from_pq(card, yaw_quat(yaw)))
            edge_x = x + self.card_length / 2 + self.BLOCK_GAP[0] + torch.rand(b) * self.BLOCK_GAP[1] \
                + self.block_height / np.tan(BLOCK_SLOPE)
            # the slab's centre from its top far edge (local (+a, 0, +c), pitched by BLOCK_SLOPE about -y)
            a, c = BLOCK_HALF[0], BLOCK_HALF[2]
            cos, sin = np.cos(BLOCK_SLOPE), np.sin(BLOCK_SLOPE)
            centre = torch.stack([edge_x - (a * cos - c * sin), y + (torch.rand(b) * 2 - 1) * self.BLOCK_Y,
                                  torch.full((b,), self.block_height - (a * sin + c * cos))], dim=1)
            pitch = torch.tensor([np.cos(BLOCK_SLOPE / 2), 0.0, -np.sin(BLOCK_SLOPE / 2), 0.0]).expand(b, 4)
            self.block.set_pose(Pose.create_from_pq(centre, pitch))

    def block_edge(self) -> torch.Tensor:
        """(b,) x of the block's top edge, where its ramp ends."""
        a, c = BLOCK_HALF[0], BLOCK_HALF[2]
        return self.block.pose.p[:, 0] + a * np.cos(BLOCK_SLOPE) - c * np.sin(BLOCK_SLOPE)

    def task_conditions(self, info: dict) -> torch.Tensor:
        info["is_tilted"] = tilt(self.card) >= TILTED
        info["above_block"] = info["height"] > self.block_height
        return info["above_block"]

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(card_pose=self.card.pose.raw_pose, block_pos=self.block.pose.p,
                       tcp_to_card=self.card.pose.p - self.ee.tcp().p)
        return obs

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # fingertip to the card, the card tilted up the block, then held and lifted
        reach = torch.linalg.norm(self.card.pose.p - leap_fingertip(self.agent), dim=1)
        reward = 1 - torch.tanh(5 * reach)
        reward += torch.where(info["is_tilted"] | info["is_grasped"], torch.ones_like(reach),
                              (self.card.pose.p[:, 0] - self.block.pose.p[:, 0]).clamp(max=0).exp())
        held = info["is_grasped"].float()
        reward += held * (1 + 2 * (info["height"] / self.lift_height).clamp(0, 1))
        reward[info["success"]] = self.max_dense_reward
        return reward
