"""CarryBoardThroughGate (L3 rigid DG, family LiftTwoHanded): carry a long board with both arms through a narrow gate
without touching its posts."""

from __future__ import annotations

from typing import Any

import numpy as np
import sapien
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply, quaternion_invert
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.agents.effectors import contact_forces
from maniladder_ms.envs import register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.tabletop import WOOD_DENSITY, boxes_builder

from .base import SIDE_SIGNS, LiftTwoHandedTask

BOARD_WIDTH, BOARD_THICKNESS = 0.05, 0.03  # across the board (what the fingers close on) and its height
POST_HALF, POST_HEIGHT = 0.015, 0.12  # the gate's two square posts: half side and height
GRASP_INSET = 0.05  # the grasp points this far in from the board's ends (the hands stay between the posts)
TOUCH_FORCE = 1e-3  # newtons: a contact force on a post above this is a touch


@register_task("CarryBoardThroughGate")
class CarryBoardThroughGateEnv(LiftTwoHandedTask):
    """**Task:** a long board lies across the table in front of the robot; a gate of two square posts stands
    further out, its opening only a little wider than the board is long. Both arms take the board near its ends,
    lift it, turn it square to the gate and carry it through between the posts without touching them.

    **Randomisation:** the board (`board_length` long along its local y, 5 x 3 cm in section, wood) lies with its
    centre uniform in x in [-0.2, -0.15], y in [-0.03, 0.03] (`BOARD_X`, `BOARD_Y`) and its yaw uniform in
    [-10, 10] degrees (`BOARD_YAW`); the gate (two fixed square posts, 3 cm side, 12 cm high, their inner faces
    `board_length` / 2 + `clearance` either side of the gate's middle along its local y) has its middle uniform
    in x in [0.04, 0.08], y in [-0.03, 0.03] (`GATE_X`, `GATE_Y`) and its yaw uniform in [-10, 10] degrees
    (`GATE_YAW`): up to 20 degrees between the board and the gate.

    **Success:** the board went through the gate carried: at some control step its centre lay between the
    posts (within the posts' depth along the gate's local x, and between their inner faces, which stand
    `board_length` / two + `clearance` either side of the gate's middle) while both grippers
    held it lifted and level (the LiftTwoHanded family's lift: bottom at least `lift_height` above the table,
    tilt below `max_tilt`, `LiftTwoHandedTask`) with its top below the posts' tops (episode memory `through`);
    at no control step did a post touch the board or any robot link (a contact force above `TOUCH_FORCE`,
    episode memory `touched`); and now the board's four footprint corners all lie past the gate's far face
    and both grippers hold it.

    **Level 3:** (against Level 2's PingPongTransport, a two-arm carry of about the same length with a tray:
    4 stages, ~130 steps, 3 cm of slack only at the final placement) the 44 cm board must pass an opening only
    `clearance` (1 cm) wider than it at each end, held 5 cm in from its ends, so both arms must keep it within
    1 cm of the gate's axis across the whole pass while nothing of the board or of either arm brushes a post at
    any step (checked every control step, not only at the end); 5 stages (grasp both ends, lift, turn the board
    by up to 20 degrees in the air with both arms on it to square it to the gate, line it up in front of the
    opening, carry it through in lock-step).
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda"]
    max_dense_reward = 10
    TASK_REGION = (-0.3, 0.3, -0.35, 0.35)
    PARAMS = LiftTwoHandedTask.PARAMS + ("board_length", "clearance")
    # layout ranges as (low, span)
    BOARD_X, BOARD_Y = (-0.2, 0.05), (-0.03, 0.06)
    BOARD_YAW = 10  # degrees either side of lying across the table (long side along y)
    GATE_X, GATE_Y = (0.04, 0.04), (-0.03, 0.06)
    GATE_YAW = 10  # degrees either side of square to the table

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        half = [BOARD_WIDTH / 2, self.board_length / 2, BOARD_THICKNESS / 2]
        # the pose origin at the board's bottom centre, as the family's lift rule reads it
        self.board = boxes_builder(self.scene, [([0, 0, BOARD_THICKNESS / 2], half)], (0.72, 0.52, 0.3, 1),
                                   density=WOOD_DENSITY).build(name="board")
        builder = self.scene.create_actor_builder()
        mat = sapien.render.RenderMaterial(base_color=[0.25, 0.25, 0.3, 1], roughness=0.5) \
            if self.scene.can_render() else None
        for sign in (1, -1):
            pose = sapien.Pose(p=[0, sign * self.post_offset, POST_HEIGHT / 2])
            post = [POST_HALF, POST_HALF, POST_HEIGHT / 2]
            builder.add_box_collision(pose, half_size=post)
            if mat is not None:
                builder.add_box_visual(pose, half_size=post, material=mat)
        builder.initial_pose = sapien.Pose()
        self.gate = builder.build_kinematic(name="gate")  # origin on the table in the middle of the opening
        self.item = self.board
        self.touch_links = [self.board] + list(self.agent.robot.links)
        self.memory.flag("through")  # carried lifted and level between the posts
        self.memory.flag("touched")  # a post touched by the board or the robot

    @property
    def post_offset(self) -> float:
        """Distance of each post's centre from the gate's middle along the gate's local y."""
        return self.board_length / 2 + self.clearance + POST_HALF

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            board = torch.stack([torch.rand(b) * self.BOARD_X[1] + self.BOARD_X[0],
                                 torch.rand(b) * self.BOARD_Y[1] + self.BOARD_Y[0], torch.zeros(b)], dim=1)
            board_q = yaw_quat((torch.rand(b) * 2 - 1) * np.deg2rad(self.BOARD_YAW))
            self.board.set_pose(Pose.create_from_pq(board, board_q))
            gate = torch.stack([torch.rand(b) * self.GATE_X[1] + self.GATE_X[0],
                                torch.rand(b) * self.GATE_Y[1] + self.GATE_Y[0], torch.zeros(b)], dim=1)
            gate_q = yaw_quat((torch.rand(b) * 2 - 1) * np.deg2rad(self.GATE_YAW))
            self.gate.set_pose(Pose.create_from_pq(gate, gate_q))

    def in_gate_frame(self, points: torch.Tensor) -> torch.Tensor:
        """(num_envs, k, 3) world `points` (num_envs, k, 3) in the gate's frame (x through the opening)."""
        gate = self.gate.pose
        q = quaternion_invert(gate.q)[:, None].expand(-1, points.shape[1], -1)
        return quaternion_apply(q, points - gate.p[:, None])

    def on_board(self, local: torch.Tensor) -> torch.Tensor:
        """(num_envs, k, 3) world positions of the points `local` (k, 3) given in the board's frame."""
        board = self.board.pose
        q = board.q[:, None].expand(-1, local.shape[0], -1)
        return board.p[:, None] + quaternion_apply(q, local[None].expand(self.num_envs, -1, -1))

    def board_corners(self) -> torch.Tensor:
        """(num_envs, 4, 3) world positions of the board's four bottom corners."""
        hx, hy = BOARD_WIDTH / 2, self.board_length / 2
        return self.on_board(torch.tensor([[sx * hx, sy * hy, 0.0] for sx in (1, -1) for sy in (1, -1)],
                                          device=self.device))

    def gate_touched(self) -> torch.Tensor:
        """(num_envs,) bool: a post feels a contact force above `TOUCH_FORCE` from the board or a robot link (the
        gate is kinematic: the table, static, makes no contacts with it)."""
        forces = contact_forces(self.scene, self.gate, self.touch_links).norm(dim=-1)
        return (forces > TOUCH_FORCE).any(dim=0)

    def between_posts(self) -> torch.Tensor:
        """(num_envs,) bool: the board's centre lies in the opening: within the posts' depth along the gate's x
        and between their inner faces along its y."""
        centre = self.in_gate_frame(self.board.pose.p[:, None])[:, 0]
        return (centre[:, 0].abs() <= POST_HALF) & (centre[:, 1].abs() <= self.post_offset - POST_HALF)

    def _update_memory(self):
        self.memory.latch("touched", self.gate_touched())
        inside = self.between_posts() & ~self.memory["through"]
        if bool(inside.any()):
            info = LiftTwoHandedTask.evaluate(self)
            low = self.board.pose.p[:, 2] + BOARD_THICKNESS <= POST_HEIGHT
            self.memory.latch("through", inside & info["success"] & low)

    def grasp_points(self) -> dict[str, torch.Tensor]:
        """World grasp points on the board's top-face centre line, `GRASP_INSET` in from each end, half the
        board's thickness down (the finger pads' middle), keyed by the arm that takes them."""
        y = self.board_length / 2 - GRASP_INSET
        local = torch.tensor([[0.0, sign * y, BOARD_THICKNESS / 2] for sign in SIDE_SIGNS.values()], device=self.device)
        return dict(zip(SIDE_SIGNS, self.on_board(local).unbind(dim=1)))

    def _get_obs_extra(self, info: dict):
        info = dict(info, carried=info["through"])
        return self.two_hand_obs(info, self.grasp_points(), "grasp", dict(
            board_pose=self.board.pose.raw_pose, gate_pose=self.gate.pose.raw_pose,
            board_to_gate=self.gate.pose.p - self.board.pose.p, touched=info["touched"]))

    def evaluate(self):
        info = LiftTwoHandedTask.evaluate(self)  # the lift: height, tilt, each gripper's hold
        corners = self.in_gate_frame(self.board_corners())
        info["past_gate"] = (corners[..., 0] > POST_HALF).all(dim=1)
        info["between_posts"] = self.between_posts()
        info["through"] = self.memory["through"]
        info["touched"] = self.memory["touched"]
        both = info["left_grasped"] & info["right_grasped"]
        info["success"] = info["through"] & ~info["touched"] & info["past_gate"] & both
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # reach and hold both ends; lift level with both; then the board's centre towards the opening and past it,
        # square to the gate; all of it nothing once a post was touched
        reward = self.reach_and_hold_reward(self.grasp_points(), info)
        both = info["left_grasped"] & info["right_grasped"]
        lift = (info["height"] / self.lift_height).clamp(0, 1) * info["is_level"]
        reward += 2 * both * lift
        centre = self.in_gate_frame(self.board.pose.p[:, None])[:, 0]
        beyond = torch.tensor([[POST_HALF + BOARD_WIDTH, 0.0]], device=self.device)
        gap = torch.linalg.norm(centre[:, :2] - beyond, dim=1)
        turn = 1 - torch.cos(self.board_yaw_to_gate()).abs()
        reward += both * lift * (3 * (1 - torch.tanh(5 * gap)) + (1 - turn))
        reward += 2 * info["through"] * info["past_gate"] * both
        reward *= (~info["touched"]).float()
        reward[info["success"]] = self.max_dense_reward
        return reward

    def board_yaw_to_gate(self) -> torch.Tensor:
        """(num_envs,) angle between the board's long axis and the line through the posts (both along local y)."""
        y = torch.tensor([[0.0, 1.0, 0.0]], device=self.device).expand(self.num_envs, 3)
        board_y = quaternion_apply(self.board.pose.q, y)
        gate_y = quaternion_apply(self.gate.pose.q, y)
        return torch.acos((board_y[:, :2] * gate_y[:, :2]).sum(dim=1).clamp(-1, 1) /
                          board_y[:, :2].norm(dim=1).clamp(min=1e-6))
