"""ReorientCubeInHand (L3 rigid SX): roll a cube lying on the palm-up LEAP hand a quarter turn with the fingers so
that its marked face points up, and hold it."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.utils.geometry.rotation_conversions import axis_angle_to_quaternion, quaternion_to_matrix
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import contact_forces
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.layout import symmetric_deg, uniform

# The arm's ready pose: the hand palm-up, fingers pointing away from the robot (+x), its TCP at (-0.1, 0, 0.38), the
# palm 10 cm below it (pinocchio IK, 40 random starts: of the solutions with the shoulder facing the hand, the one
# furthest from the joint limits, 0.44 rad). With the TCP at 0.28 the wrist, under the palm-up hand, lay in the
# table and the first control step threw the arm 6 cm up
READY_ARM_JOINTS = (-0.626, 0.934, 0.512, -2.144, 1.865, 0.424, -0.16)
# where the cube lies on the open palm-up hand, in the TCP frame (x along the fingers, z out of the palm): over the
# finger bases (its edge nearest the heel ~0.5 cm past the knuckles, at x = 1.7 cm), across the middle finger (y), at
# the height it settles to on the flat fingers. Centred over the palm's heel side instead (x = 2.6 cm), the curling
# fingers tipped it only 35 degrees before it met the thumb's base, and 2.3 cm towards the index finger (y = -0.8 cm)
# cubes turned +20 to +40 degrees fell off the hand's side as they tipped (seeds 104, 109, 112)
CUBE_ON_PALM = (0.045, 0.015, -0.06)
MARK_COLOR = (0.9, 0.15, 0.1, 1)
CUBE_COLOR = (0.92, 0.88, 0.75, 1)
MARK_INSET = 0.004  # m the marked square stops short of the face's edges
MARK_THICKNESS = 0.0005  # m the (visual-only) mark stands off the face


def build_marked_cube(scene, name: str, half: float, mass: float, friction: float):
    """A cube of side 2 `half` and `mass` kg, its +x face marked with a red square (visual only)."""
    builder = scene.create_actor_builder()
    builder.add_box_collision(half_size=[half] * 3, material=physx.PhysxMaterial(friction, friction, 0.0),
                              density=mass / (2 * half) ** 3)
    if scene.can_render():
        builder.add_box_visual(half_size=[half] * 3,
                               material=sapien.render.RenderMaterial(base_color=list(CUBE_COLOR), roughness=0.7))
        builder.add_box_visual(sapien.Pose(p=[half + MARK_THICKNESS / 2, 0, 0]),
                               half_size=[MARK_THICKNESS, half - MARK_INSET, half - MARK_INSET],
                               material=sapien.render.RenderMaterial(base_color=list(MARK_COLOR), roughness=0.5))
    builder.initial_pose = sapien.Pose(p=[0, 0, 1])
    return builder.build(name=name)


def _angle_deg(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """(n,) angle in degrees between unit vectors a, b (n, 3)."""
    return torch.rad2deg(torch.arccos((a * b).sum(dim=1).clamp(-1, 1)))


@register_task("ReorientCubeInHand")
class ReorientCubeInHandEnv(ManiLadderEnv):
    """**Task:** a cube lies on the open LEAP hand, held palm-up above the table, one of its faces marked red and
    pointing sideways, along the fingers; turn the cube in the hand with the fingers so that the marked face points
    up, and hold it there, off the table.

    **Randomisation:**
    - the cube (5 cm, `cube_half`; `cube_mass`; friction `cube_friction`) lies on the hand's finger bases
      (`CUBE_ON_PALM`), its centre offset from there uniform in +- `cube_max_offset` along the palm's two axes, its
      yaw about the palm normal uniform in +- `cube_max_yaw` (the marked face is the side face nearest the
      fingertips' direction; a cube turned near its diagonal tips over a corner);
    - the arm starts in a ready pose (`READY_JOINTS`, plus the usual joint noise): palm-up, fingers pointing away
      from the robot, the palm ~28 cm above the table.

    **Success:** the marked face's outward normal is within `max_face_angle` of +z; the hand holds the cube
    (`ee.holds`: a finger pressing it against the thumb or palm), the cube does not touch the table and its centre
    is at least `min_height` above it; and the cube was turned in the hand: the marked face's normal, expressed in
    the hand's frame (the TCP's, fixed to the palm), is at least `min_hand_turn` away from where it was at the start
    or at the last step the cube touched the table (episode memory `normal_in_hand`). Turning the wrist with the cube
    clamped leaves the normal where it is in the hand's frame, and a cube rolled on the table starts over from the
    pose in which it left the table, so neither counts.

    **Level 3:** (against Level 2's SX tasks, PlaceMugOnCoasterHand and SlideCardToEdgeHand: grasps, carries and
    releases in which the object keeps its pose in the hand, 1-2 cm and 10 degree tolerances) a 90 degree in-hand
    rotation with the contacts switching, the hand the cube's only support: the knuckles lift the cube's far side,
    it pivots on its edge nearest the heel, past its balance point, and drops onto the palm (the fingers' first
    links, then the palm, carry it), and the fingers curl over it again; the marked face must end within 20 degrees
    of up with the cube held, in a frame where a wrist turn does not count. The rotation is short (the scripted demo
    takes 47 steps), but it has no slack: a cube 2.3 cm off the hand's middle falls off its side as it tips, and
    one 2 cm nearer the heel stalls at 35 degrees against the thumb.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 5
    TASK_REGION = (-0.25, 0.05, -0.12, 0.12)  # the table under the palm-up hand, where a dropped cube lands
    PARAMS = ("max_face_angle", "min_hand_turn", "min_height", "cube_half", "cube_mass", "cube_friction",
              "cube_max_offset", "cube_max_yaw")
    READY_JOINTS = {f"panda_joint{i}": angle for i, angle in enumerate(READY_ARM_JOINTS, 1)}
    MARK_AXIS = 0  # the marked face: the cube's +x face

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.cube = build_marked_cube(self.scene, "cube", self.cube_half, self.cube_mass, self.cube_friction)
        # the marked face's normal in the hand's (TCP) frame at the start, or when the cube last touched the table
        self.memory.value("normal_in_hand", 3)

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            offset = torch.tensor(CUBE_ON_PALM).repeat(b, 1)
            spread = (-self.cube_max_offset, self.cube_max_offset)
            offset[:, :2] += torch.stack([uniform(b, spread), uniform(b, spread)], dim=1)
            yaw = symmetric_deg(b, self.cube_max_yaw)
            in_hand = Pose.create_from_pq(offset, axis_angle_to_quaternion(
                torch.stack([torch.zeros(b), torch.zeros(b), yaw], dim=1)))
            tcp = self.ee.tcp()  # the arm's links are where reset put them
            self.cube.set_pose(tcp[env_idx] * in_hand if self.num_envs > b else tcp * in_hand)
            self.cube.set_linear_velocity(torch.zeros(b, 3))
            self.cube.set_angular_velocity(torch.zeros(b, 3))
            self.memory.store("normal_in_hand", quaternion_to_matrix(in_hand.q)[:, :, self.MARK_AXIS], env_idx)

    # ---- measurements ------------------------------------------------------------------------------------------
    def marked_normal(self, q: torch.Tensor | None = None) -> torch.Tensor:
        """(n, 3) world direction of the marked face's outward normal (of the cube, or of a cube at orientation `q`)."""
        return quaternion_to_matrix(self.cube.pose.q if q is None else q)[:, :, self.MARK_AXIS]

    def normal_in_hand(self) -> torch.Tensor:
        """(n, 3) the marked face's normal in the hand's (TCP) frame."""
        r = quaternion_to_matrix(self.ee.tcp().q)
        return (r.transpose(1, 2) @ self.marked_normal().unsqueeze(-1)).squeeze(-1)

    def on_table(self) -> torch.Tensor:
        return contact_forces(self.scene, self.ladder_scene.table, [self.cube])[0].norm(dim=1) > 1e-3

    def _update_memory(self):
        touching = self.on_table()
        if touching.any():
            now = self.normal_in_hand()
            self.memory.store("normal_in_hand", now[touching], torch.nonzero(touching).flatten())

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(cube_pose=self.cube.pose.raw_pose, tcp_to_cube_pos=self.cube.pose.p - self.ee.tcp().p,
                       marked_normal=self.marked_normal())
        return obs

    def evaluate(self):
        up = torch.tensor([0.0, 0.0, 1.0], device=self.device).expand(self.num_envs, 3)
        face_angle = _angle_deg(self.marked_normal(), up)
        hand_turn = _angle_deg(self.normal_in_hand(), self.memory["normal_in_hand"])
        is_grasped = self.ee.holds(self.cube)
        on_table = self.on_table()
        height = self.cube.pose.p[:, 2]
        face_up = face_angle <= self.max_face_angle
        turned_in_hand = hand_turn >= self.min_hand_turn
        is_high = height >= self.min_height
        return {
            "success": face_up & turned_in_hand & is_grasped & ~on_table & is_high,
            "face_up": face_up,
            "turned_in_hand": turned_in_hand,
            "is_grasped": is_grasped,
            "on_table": on_table,
            "is_high": is_high,
            "face_angle": face_angle,
            "hand_turn": hand_turn,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # turn the marked face up (in the hand), keep the cube high and off the table, hold it
        turn = 1 - info["face_angle"] / 180
        in_hand = (info["hand_turn"] / self.min_hand_turn).clamp(0, 1)
        kept = (info["is_high"] & ~info["on_table"]).float()
        reward = kept * (2 * turn + in_hand + info["is_grasped"].float())
        reward[info["success"]] = self.max_dense_reward
        return reward
