"""PlugUSB (L3 rigid SG): insert a keyed USB-style plug into its socket, the right way round."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import quaternion_apply
from mani_skill.utils.structs.pose import Pose

from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.geometry import yaw_quat
from maniladder_ms.objects.usb import USBShape, build_usb_plug, build_usb_socket

# metres from the TCP: a gripper further than this from the plug's tip cannot hold it (the plug is 4.2 cm long,
# the finger pads within 3 cm of the TCP); the contact query (costly on CPU) is skipped there
HOLD_REACH = 0.08


@register_task("PlugUSB")
class PlugUSBEnv(ManiLadderEnv):
    """**Task:** a USB-style plug stands on its tip on the table; insert it into the slot of a socket fixed to
    the table. The plug's connector carries a key rib on one face and the slot a groove on one side: the plug
    goes in only the right way round (a plug turned half a turn is stopped by the socket's top face).

    **Randomisation:**
    - the plug stands upright with a uniform random yaw over the whole turn (its rib may face any way), its
      tip's centre uniform in x in `PLUG_X` = [-0.15, 0.0], |y| in `PLUG_ABS_Y` = [0.08, 0.2] on a random side
      of the robot's centre line;
    - the socket (a fixture; slot 2 x `shell_half_x` + `clearance` by 2 x `shell_half_y` + `clearance`,
      `USBShape.slot_depth` deep) stands on the other side, its centre x in `SOCKET_X` = [-0.1, 0.05], |y| in
      `SOCKET_ABS_Y` = [0.06, 0.18], its yaw uniform in +-`SOCKET_MAX_YAW` = +-pi/4.

    **Success:** the plug is in the socket: the centre of its tip, in the socket's frame, lies at least
    `insert_depth` below the socket's top face and inside the slot's opening (half sizes `shell_half_x` and
    `shell_half_y`, each plus half the `clearance`); the plug's yaw is within
    `max_yaw_error` of the socket's (its rib in the groove); and the gripper does not hold the plug
    (`ee.holds`: it stays plugged in on its own).

    **Level 3:** (against Level 2's InsertPegInHole: a 3 cm square peg into a hole with 1 mm of play on each
    side, any of four yaws, three stages, ~110 steps) the 12 x 5 mm connector must enter a slot with 0.5 mm of
    play on each side (1 mm in all) and only one of its yaws fits: the keyed plug, its rib facing any way at
    reset, has to be turned in the hand by up to half a turn to meet the groove (4 stages: grasp, turn,
    line up, insert, ~130 steps, at most ~210); a plug pushed in half a turn off is stopped by 1 mm of the
    rib on the top face.
    """

    max_dense_reward = 7
    TASK_REGION = (-0.2, 0.1, -0.25, 0.25)
    PARAMS = ("shell_half_x", "shell_half_y", "clearance", "insert_depth", "max_yaw_error")
    PLUG_X, PLUG_ABS_Y = (-0.15, 0.0), (0.08, 0.2)  # ranges of the plug tip's x and |y|
    SOCKET_X, SOCKET_ABS_Y = (-0.1, 0.05), (0.06, 0.18)  # ranges of the socket centre's x and |y| (other side)
    SOCKET_MAX_YAW = np.pi / 4

    @property
    def shape(self) -> USBShape:
        return USBShape(shell_half_x=self.shell_half_x, shell_half_y=self.shell_half_y, clearance=self.clearance)

    def _load_scene(self, options: dict):
        super()._load_scene(options)
        self.plug = build_usb_plug(self.scene, "usb_plug", self.shape, housing_color=(0.12, 0.3, 0.8, 1))
        self.socket = build_usb_socket(self.scene, "usb_socket", self.shape, color=(0.85, 0.85, 0.82, 1))

    def _initialize_episode(self, env_idx: torch.Tensor, options: dict):
        super()._initialize_episode(env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            side = torch.where(torch.rand(b) < 0.5, -1.0, 1.0)
            (x_lo, x_hi), (y_lo, y_hi) = self.PLUG_X, self.PLUG_ABS_Y
            plug_xyz = torch.stack([x_lo + torch.rand(b) * (x_hi - x_lo), side * (y_lo + torch.rand(b) * (y_hi - y_lo)),
                                    torch.zeros(b)], dim=1)
            self.plug.set_pose(Pose.create_from_pq(plug_xyz, yaw_quat((2 * torch.rand(b) - 1) * np.pi)))
            (x_lo, x_hi), (y_lo, y_hi) = self.SOCKET_X, self.SOCKET_ABS_Y
            socket_xyz = torch.stack([x_lo + torch.rand(b) * (x_hi - x_lo), -side * (y_lo + torch.rand(b) * (y_hi - y_lo)),
                                      torch.zeros(b)], dim=1)
            self.socket.set_pose(Pose.create_from_pq(socket_xyz, yaw_quat((2 * torch.rand(b) - 1) * self.SOCKET_MAX_YAW)))

    def insertion_state(self) -> dict[str, torch.Tensor]:
        """`depth` (m of the plug's tip below the socket's top face, in the socket's frame), `offset` (m, the tip's
        lateral distance from the slot's axis), `yaw_error` (rad, the plug's yaw from the socket's, signed)."""
        rel = self.socket.pose.inv() * self.plug.pose
        local = rel.p
        slot_x, slot_y = self.shape.slot_half
        depth = self.shape.socket_top - local[:, 2]
        in_opening = (local[:, 0].abs() <= slot_x) & (local[:, 1].abs() <= slot_y)
        # the angle about the socket's axis of the plug's x axis seen in the socket's frame
        x_axis = quaternion_apply(rel.q, torch.tensor([1.0, 0.0, 0.0], device=self.device).expand_as(local))
        yaw_error = torch.atan2(x_axis[:, 1], x_axis[:, 0])
        is_keyed = yaw_error.abs() <= np.deg2rad(self.max_yaw_error)
        return dict(depth=depth, offset=local[:, :2].norm(dim=1), yaw_error=yaw_error, in_opening=in_opening,
                    is_keyed=is_keyed, is_inserted=(depth >= self.insert_depth) & in_opening & is_keyed)

    def holds_plug(self) -> torch.Tensor:
        near = torch.linalg.norm(self.ee.tcp().p - self.plug.pose.p, dim=1) <= HOLD_REACH
        if not bool(near.any()):
            return near
        return self.ee.holds(self.plug) & near

    def _get_obs_extra(self, info: dict):
        obs = dict(tcp_pose=self.ee.tcp().raw_pose, is_grasped=info["is_grasped"])
        if "state" in self.obs_mode:
            obs.update(plug_pose=self.plug.pose.raw_pose, socket_pose=self.socket.pose.raw_pose,
                       tcp_to_plug_pos=self.plug.pose.p - self.ee.tcp().p,
                       plug_to_socket_pos=self.socket.pose.p - self.plug.pose.p)
        return obs

    def evaluate(self):
        info = self.insertion_state()
        info["is_grasped"] = self.holds_plug()
        info["success"] = info["is_inserted"] & ~info["is_grasped"]
        return info

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        grasp_p = self.plug.pose.p.clone()
        grasp_p[:, 2] += self.shape.connector_length + self.shape.housing_half[2]
        reward = 1 - torch.tanh(5 * torch.linalg.norm(grasp_p - self.ee.tcp().p, dim=1))
        is_grasped = info["is_grasped"]
        reward += is_grasped
        # while held or once in: the tip over the slot, turned to the groove, then down to the depth
        to_mouth = info["offset"] + (-info["depth"]).clamp(min=0)
        align = (1 - torch.tanh(10 * to_mouth)) + (1 - info["yaw_error"].abs() / np.pi)
        deep = (info["depth"] / self.insert_depth).clamp(0, 1) * (info["in_opening"] & info["is_keyed"])
        reward += (align + deep) * (is_grasped | info["is_inserted"])
        reward += (info["is_inserted"] & ~is_grasped).float()
        reward[info["success"]] = self.max_dense_reward
        return reward
