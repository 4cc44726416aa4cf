"""UseScrewdriverHand (L3 rigid SX): pick a screwdriver out of its stand and turn a flush cross-slot screw half a
turn with it, the LEAP hand never touching the screw."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import sapien.physx as physx
import sapien.render
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.layout import uniform, uniform_deg
from maniladder_ms.objects.controls import UP_AXIS, X_TO_Z, friction_drive

# ---- the screw: a square head with a cross slot, turning on a revolute joint in a fixed block, its top flush --
SLOT_HALF_WIDTH = 0.0025  # m: the cross slot is 5 mm wide (a LEAP fingertip is ~2 cm wide: only a blade goes in)
HEAD_QUADRANT = 0.009  # m: each of the head's four solid quarters is a 9 mm square (the slot between them)
HEAD_HALF = SLOT_HALF_WIDTH + HEAD_QUADRANT  # 1.15 cm: the head is a 2.3 cm square
SLOT_DEPTH = 0.008  # m: the slot's depth below the head's top face
HEAD_BASE = 0.004  # m: the solid disc under the slot
HEAD_HEIGHT = HEAD_BASE + SLOT_DEPTH
HEAD_DENSITY = 7800.0  # steel
BLOCK_HALF = 0.04  # m: the fixed block is an 8 cm square
BLOCK_HEIGHT = 0.03  # m: its top face, flush with the head's top, is 3 cm above the table
# the pocket the head turns in: square, its half width the head's corner radius plus this (a fingertip does not fit
# into the gap, 2-7 mm wide, between the turning head and the pocket's walls)
POCKET_CLEARANCE = 0.002
POCKET_HALF = HEAD_HALF * np.sqrt(2) + POCKET_CLEARANCE
HEAD_GAP = 0.001  # m between the head's underside and the pocket's floor (the head touches only its joint)
SCREW_DAMPING = 50.0  # N m s / rad: the friction drive saturates at `screw_torque` as soon as the head turns

# ---- the screwdriver (frame: origin on its axis at the handle's bottom face, +z along the handle) ------------
# a flat handle, 2.5 cm thick along the screwdriver's x (the blade's width) and 8 cm wide along its y, with an end
# cap over its top: the LEAP hand's finger row (knuckles 4.6 cm apart) closes on one broad face and the thumb on
# the other. An octagonal handle 3.6 cm across was narrower than the finger row: in the lift it went to the middle/
# ring side or, on ~1 seed in 8, pinched between the index tip and the thumb only, about which it then pivoted out.
# The flat handle went to the middle/ring side on 6/6 seeds (100 101 102 114 123 146), but without the cap it slid
# 2.3-3.9 cm down through the fingertips in the lift and hung from its top edge 15-18 degrees tilted; the cap,
# 8 mm past the faces, stops the slide at 0.6-1.4 cm and leaves 6-8 degrees of tilt after the alignment (one seed
# 16; 100 101 102 105 114 123)
HANDLE_HALF = (0.0125, 0.04)  # m: half its thickness (x) and half its width (y)
HANDLE_LENGTH = 0.09
CAP_OVERHANG = 0.008  # m the end cap reaches past the handle's faces
CAP_THICKNESS = 0.008
HANDLE_DENSITY = 600.0  # hard plastic / wood: ~0.15 kg with the cap and the shaft
HANDLE_FRICTION = 2.0  # a rubber grip (the LEAP fingertip pads' value)
SHAFT_RADIUS = 0.0035
SHAFT_LENGTH = 0.06
SHAFT_DENSITY = 7800.0
BLADE_HALF = (0.006, 0.001, 0.005)  # m: a flat blade 1.2 cm wide, 2 mm thick, 1 cm long at the shaft's end
TIP_Z = -(SHAFT_LENGTH + 2 * BLADE_HALF[2])  # the blade's end (the tip) in the screwdriver's frame
# the tip (the blade end's centre) counts as in the slot within this of the screw's axis, below the head's top: a
# point there lies inside the square head, whose four quarters are solid, so it is in the slot. (The blade's centre
# can sit 6-7 mm out along a slot arm, its outer end over the gap round the head: measured in the turn on seed 102.)
TIP_TOLERANCE = HEAD_HALF

# ---- the stand: a square column with a hole the shaft hangs in, the handle resting on its top ----------------
STAND_HALF = 0.025
STAND_HOLE_HALF = 0.009  # the blade's half diagonal is 6.1 mm
STAND_HEIGHT = -TIP_Z + 0.005  # the tip hangs 5 mm above the table
REST_LIFT = 0.0005  # m: the screwdriver starts this far above the stand's top (it settles onto it)

METAL, DARK = (0.72, 0.73, 0.75, 1), (0.12, 0.12, 0.13, 1)


def _mat(color):
    return sapien.render.RenderMaterial(base_color=list(color), roughness=0.4)


def build_screw(scene, name: str, screw_torque: float):
    """The screw articulation: the fixed block (root, origin on the table under the screw's axis) with the square
    pocket, and the head (link `<name>_head`) on a revolute joint about the vertical, positive counter-clockwise
    from above, unlimited, held by a friction drive of `screw_torque` N m."""
    builder = scene.create_articulation_builder()
    block = builder.create_link_builder()
    block.set_name(f"{name}_block")
    floor = BLOCK_HEIGHT - HEAD_HEIGHT - HEAD_GAP
    side = (BLOCK_HALF - POCKET_HALF) / 2
    parts = [([0, 0, floor / 2], [BLOCK_HALF, BLOCK_HALF, floor / 2])]
    wall_h = (BLOCK_HEIGHT - floor) / 2
    for sx in (-1, 1):
        parts.append(([sx * (POCKET_HALF + side), 0, floor + wall_h], [side, BLOCK_HALF, wall_h]))
        parts.append(([0, sx * (POCKET_HALF + side), floor + wall_h], [POCKET_HALF, side, wall_h]))
    for centre, half in parts:
        block.add_box_collision(sapien.Pose(p=centre), half_size=half)
        block.add_box_visual(sapien.Pose(p=centre), half_size=half, material=_mat((0.55, 0.42, 0.28, 1)))

    head = builder.create_link_builder(block)
    head.set_name(f"{name}_head")
    base = sapien.Pose(p=[0, 0, HEAD_BASE / 2])  # head frame: origin on the axis at its underside
    head.add_box_collision(base, half_size=[HEAD_HALF, HEAD_HALF, HEAD_BASE / 2], density=HEAD_DENSITY)
    head.add_box_visual(base, half_size=[HEAD_HALF, HEAD_HALF, HEAD_BASE / 2], material=_mat(DARK))
    c = SLOT_HALF_WIDTH + HEAD_QUADRANT / 2
    for sx in (-1, 1):
        for sy in (-1, 1):
            quad = sapien.Pose(p=[sx * c, sy * c, HEAD_BASE + SLOT_DEPTH / 2])
            half = [HEAD_QUADRANT / 2, HEAD_QUADRANT / 2, SLOT_DEPTH / 2]
            head.add_box_collision(quad, half_size=half, density=HEAD_DENSITY)
            head.add_box_visual(quad, half_size=half, material=_mat(METAL))
    head.set_joint_name(f"{name}_joint")
    head.set_joint_properties("revolute_unwrapped", limits=[[-np.inf, np.inf]],
                              pose_in_parent=sapien.Pose(p=[0, 0, floor + HEAD_GAP]) * UP_AXIS,
                              pose_in_child=UP_AXIS)
    builder.initial_pose = sapien.Pose()
    screw = builder.build(name, fix_root_link=True)
    friction_drive(screw.active_joints[0], SCREW_DAMPING, screw_torque)
    return screw


def build_screwdriver(scene, name: str):
    """The screwdriver (dynamic; frame: see the constants above)."""
    builder = scene.create_actor_builder()
    grip = physx.PhysxMaterial(HANDLE_FRICTION, HANDLE_FRICTION, 0.0)
    red = _mat((0.85, 0.2, 0.1, 1))
    handle = sapien.Pose(p=[0, 0, HANDLE_LENGTH / 2], q=[1.0, 0.0, 0.0, 0.0])
    handle_half = [HANDLE_HALF[0], HANDLE_HALF[1], HANDLE_LENGTH / 2]
    builder.add_box_collision(handle, half_size=handle_half, material=grip, density=HANDLE_DENSITY)
    builder.add_box_visual(handle, half_size=handle_half, material=red)
    cap = sapien.Pose(p=[0, 0, HANDLE_LENGTH + CAP_THICKNESS / 2])
    cap_half = [HANDLE_HALF[0] + CAP_OVERHANG, HANDLE_HALF[1] + CAP_OVERHANG, CAP_THICKNESS / 2]
    builder.add_box_collision(cap, half_size=cap_half, material=grip, density=HANDLE_DENSITY)
    builder.add_box_visual(cap, half_size=cap_half, material=red)
    shaft = sapien.Pose(p=[0, 0, -SHAFT_LENGTH / 2]) * X_TO_Z
    builder.add_cylinder_collision(shaft, radius=SHAFT_RADIUS, half_length=SHAFT_LENGTH / 2, density=SHAFT_DENSITY)
    builder.add_cylinder_visual(shaft, radius=SHAFT_RADIUS, half_length=SHAFT_LENGTH / 2, material=_mat(METAL))
    blade = sapien.Pose(p=[0, 0, TIP_Z + BLADE_HALF[2]])
    builder.add_box_collision(blade, half_size=list(BLADE_HALF), density=SHAFT_DENSITY)
    builder.add_box_visual(blade, half_size=list(BLADE_HALF), material=_mat(METAL))
    builder.initial_pose = sapien.Pose(p=[0, 0, STAND_HEIGHT + REST_LIFT])
    return builder.build(name=name)


def build_stand(scene, name: str):
    """The stand (kinematic; origin on the table under the hole's axis): four walls round the hole."""
    builder = scene.create_actor_builder()
    side = (STAND_HALF - STAND_HOLE_HALF) / 2
    h = STAND_HEIGHT / 2
    for sx in (-1, 1):
        for centre, half in (([sx * (STAND_HOLE_HALF + side), 0, h], [side, STAND_HALF, h]),
                             ([0, sx * (STAND_HOLE_HALF + side), h], [STAND_HOLE_HALF, side, h])):
            builder.add_box_collision(sapien.Pose(p=centre), half_size=half)
            builder.add_box_visual(sapien.Pose(p=centre), half_size=half, material=_mat((0.3, 0.35, 0.5, 1)))
    builder.initial_pose = sapien.Pose()
    return builder.build_kinematic(name=name)


@register_task("UseScrewdriverHand")
class UseScrewdriverHandEnv(ManiLadderEnv):
    """**Task:** a screwdriver (a flat handle 8 x 2.5 x 9 cm with an end cap, a 6 cm shaft, a flat blade) stands
    upright in a stand, its shaft in the stand's hole and its handle resting on top; a screw's square head (2.3 cm, a cross slot 5 mm wide and 8 mm deep) sits flush with the top of a
    fixed block, in a pocket too narrow for a fingertip, its turn resisted by friction. Pick the screwdriver up
    by its handle with the LEAP hand, set its flat blade into the slot and turn the screw half a turn by turning
    the wrist (either way), the hand holding the screwdriver and never touching the screw.

    **Randomisation:** the screw block's centre uniform in x in `screw_x_range`, y in `screw_y_range`, its yaw
    (where the slot's arms point; the cross repeats every 90 degrees) uniform in `screw_yaw_range`; the stand's
    centre uniform in x in `stand_x_range`, y in `stand_y_range`, its yaw (and the screwdriver's: where its blade
    points) uniform in `stand_yaw_range`. The screw starts at joint angle 0.

    **Success:** the screw's joint has turned by at least `turn_angle` from its start (either way), and so has
    the episode memory `tool_turn`, which sums the joint's change only over control steps in which the hand
    drove it with the screwdriver (at the step's start or end): the hand holds the screwdriver (`ee.holds`),
    the screwdriver's tip is in the slot (the blade's end within `TIP_TOLERANCE` of the screw's axis and at
    least `tip_depth` below the head's top) and no hand link touches the screw's head (`ee.touches`); and all
    three hold at the end. The screw resists with `screw_torque` of dry friction, so it stays where it is
    left. A turn made otherwise (a fingertip on the head, a loose screwdriver) does not count.

    **Level 3:** (against Level 2's UnscrewCapHand: the hand grips the cap itself and turns it 360 degrees,
    ~470 control steps, the grasp centred on the cap within ~1 cm) the hand turns the screw only through a
    tool: 5 stages (grasp the handle, lift the screwdriver out of its 7.5 cm stand, carry it and turn the
    blade into line with the slot, set the tip into the slot, turn), the blade 2 mm thick in a 5 mm slot
    (1.5 mm of play across it, within ~14 degrees of its line), its tip guided 10 cm below the hand through a
    grasp that gives, and kept in the slot through the turn while the hand holds the tool by friction only.
    """

    SUPPORTED_ROBOTS = ["ml_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, -0.03, -0.17, 0.17)
    PARAMS = ("turn_angle", "screw_torque", "tip_depth", "screw_x_range", "screw_y_range", "screw_yaw_range",
              "stand_x_range", "stand_y_range", "stand_yaw_range")

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.screw = build_screw(self.scene, "screw", self.screw_torque)
        self.head = self.screw.links_map["screw_head"]
        self.screwdriver = build_screwdriver(self.scene, "screwdriver")
        self.stand = build_stand(self.scene, "stand")
        self.memory.value("last_angle")  # the screw's joint angle after the last step
        self.memory.value("last_driving")  # 1 where the hand drove the screw with the screwdriver after the last step
        self.memory.value("tool_turn")  # rad the joint turned in steps the hand drove it with the screwdriver

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            xyz = torch.stack([uniform(b, self.screw_x_range), uniform(b, self.screw_y_range), torch.zeros(b)], dim=1)
            self.screw.set_pose(Pose.create_from_pq(xyz, yaw_quat(uniform_deg(b, self.screw_yaw_range))))
            self.screw.set_qpos(torch.zeros(b, 1))
            self.screw.set_qvel(torch.zeros(b, 1))
            xyz = torch.stack([uniform(b, self.stand_x_range), uniform(b, self.stand_y_range), torch.zeros(b)], dim=1)
            q = yaw_quat(uniform_deg(b, self.stand_yaw_range))
            self.stand.set_pose(Pose.create_from_pq(xyz, q))
            xyz[:, 2] = STAND_HEIGHT + REST_LIFT
            self.screwdriver.set_pose(Pose.create_from_pq(xyz, q))
            self.screwdriver.set_linear_velocity(torch.zeros(b, 3))
            self.screwdriver.set_angular_velocity(torch.zeros(b, 3))
            self.memory.store("last_angle", torch.zeros(b, 1), env_idx)

    # ---- geometry the rule, the reward and the solver read --------------------------------------------------
    def screw_angle(self) -> torch.Tensor:
        """(num_envs,) the head's joint angle (rad, counter-clockwise from above, accumulated over turns)."""
        return self.screw.get_qpos()[:, 0]

    def head_top(self) -> torch.Tensor:
        """(num_envs, 3) the centre of the head's top face (on the screw's axis, flush with the block)."""
        return self.screw.pose.p + torch.tensor([0.0, 0.0, BLOCK_HEIGHT], device=self.device)

    def tip(self) -> torch.Tensor:
        """(num_envs, 3) the screwdriver's tip: the centre of the blade's end."""
        tool = self.screwdriver.pose  # a pose product's position part alone (the rule reads it ~5 times a step)
        blade_end = torch.tensor([[0.0, 0.0, TIP_Z]], device=self.device).expand_as(tool.p)
        return tool.p + quaternion_apply(tool.q, blade_end)

    def tip_in_slot(self) -> torch.Tensor:
        tip, top = self.tip(), self.head_top()
        near = torch.linalg.norm(tip[:, :2] - top[:, :2], dim=1) <= TIP_TOLERANCE
        return near & (tip[:, 2] <= top[:, 2] - self.tip_depth)

    def _driving(self) -> dict[str, torch.Tensor]:
        held = self.ee.holds(self.screwdriver)
        in_slot = self.tip_in_slot()
        touch = self.ee.touches(self.head)
        return dict(screwdriver_held=held, tip_in_slot=in_slot, head_touched=touch, driving=held & in_slot & ~touch)

    def _update_memory(self):
        super()._update_memory()
        angle = self.screw_angle()
        driving = self._driving()["driving"]
        counted = driving | (self.memory["last_driving"][:, 0] > 0.5)
        delta = angle - self.memory["last_angle"][:, 0]
        self.memory.store("tool_turn", self.memory["tool_turn"] + torch.where(counted, delta, 0.0)[:, None])
        self.memory.store("last_angle", angle[:, None])
        self.memory.store("last_driving", driving.float()[:, None])

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, screw_angle=info["screw_angle"], tool_turn=info["tool_turn"])
        if "state" in self.obs_mode:
            obs.update(screw_pose=self.screw.pose.raw_pose, screwdriver_pose=self.screwdriver.pose.raw_pose,
                       tip=self.tip(), head_top=self.head_top())
        return obs

    def evaluate(self):
        flags = self._driving()
        angle = self.screw_angle()
        tool_turn = self.memory["tool_turn"][:, 0]
        turn = np.deg2rad(self.turn_angle)
        turned = (tool_turn.abs() >= turn) & (angle.abs() >= turn) & (tool_turn * angle > 0)
        lifted = self.tip()[:, 2] > STAND_HEIGHT
        return dict(success=turned & flags["driving"], screw_angle=angle, tool_turn=tool_turn, lifted=lifted, **flags)

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        handle = self.screwdriver.pose.p + torch.tensor([0.0, 0.0, HANDLE_LENGTH / 2], device=self.device)
        reach = 1 - torch.tanh(5 * torch.linalg.norm(handle - self.ee.tcp().p, dim=1))
        held = info["screwdriver_held"].float()
        aim = 1 - torch.tanh(10 * torch.linalg.norm(self.tip() - self.head_top(), dim=1))
        progress = (info["tool_turn"].abs() / np.deg2rad(self.turn_angle)).clamp(0, 1)
        reward = reach + held * (1 + aim) + info["driving"].float() * (1 + 2 * progress) - info["head_touched"].float()
        reward[info["success"]] = self.max_dense_reward
        return reward
