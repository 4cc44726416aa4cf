"""Turn a solver's joint-position targets into the actions of the env's own control mode.

Solvers command absolute arm joint targets plus a gripper value (`pd_joint_pos` actions). Wrapping
the env in `JointTargetAdapter` lets the same solver record natively in `pd_joint_delta_pos` or
`pd_ee_delta_pose`: each step the target is re-expressed relative to the robot's current state, so
the recorded actions are exactly what the env executed (no offline conversion, no drift).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import torch

from mani_skill.utils.geometry.rotation_conversions import matrix_to_euler_angles, quaternion_to_matrix
from mani_skill.utils.structs.pose import Pose

from . import JOINT_TARGET_MODES


class JointTargetAdapter(gym.Wrapper):
    """Accepts `[arm joint targets..., gripper]` actions; steps the wrapped env in its own control mode."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        base = env.unwrapped
        self.mode = base.control_mode
        if self.mode not in JOINT_TARGET_MODES:
            raise ValueError(f"joint-target solvers can record in {', '.join(JOINT_TARGET_MODES)}; not in {self.mode!r}")
        self.arm = base.agent.controller.controllers["arm"]
        self.n_arm = len(self.arm.joints)
        if self.mode == "pd_ee_delta_pose":
            articulation = base.agent.robot._objs[0]
            self._pinocchio = articulation.create_pinocchio_model()
            self._ee_index = articulation.get_links().index(self.arm.ee_link._objs[0])
            active = articulation.get_active_joints()
            self._arm_qpos_index = [active.index(joint._objs[0]) for joint in self.arm.joints]

    def step(self, action):
        action = np.asarray(action, dtype=np.float32)
        target, gripper = action[: self.n_arm], action[self.n_arm :]
        if self.mode == "pd_joint_delta_pos":
            arm_action = self._normalize(target - self.arm.qpos[0].cpu().numpy())
        elif self.mode == "pd_ee_delta_pose":
            arm_action = self._normalize(self._ee_delta(target))
        else:
            arm_action = target
        return self.env.step(np.concatenate([arm_action, gripper]).astype(np.float32))

    def _normalize(self, delta: np.ndarray) -> np.ndarray:
        """Controller units -> the normalised [-1, 1] action the controller expects (clipped)."""
        low, high = self.arm.action_space_low.cpu().numpy(), self.arm.action_space_high.cpu().numpy()
        return np.clip(2 * (delta - low) / (high - low) - 1, -1, 1)

    def _ee_delta(self, target_qpos: np.ndarray) -> np.ndarray:
        """(dx, dy, dz, droll, dpitch, dyaw) taking the current TCP to its pose at `target_qpos`, in the
        controller's frame (translation in the robot root frame, rotation root-aligned)."""
        full = self.unwrapped.agent.robot.get_qpos()[0].cpu().numpy().copy()
        full[self._arm_qpos_index] = target_qpos
        self._pinocchio.compute_forward_kinematics(full)
        goal = self._pinocchio.get_link_pose(self._ee_index)
        current = self.arm.ee_pose_at_base
        goal_q = torch.as_tensor(np.asarray(goal.q), dtype=torch.float32)[None]
        # ManiSkill 3.0.1's PDEEPoseController turns a rotation action r into the rotation that takes the
        # goal to the current orientation (measured here: +0.03 rad about z turns the TCP by -0.03 rad);
        # its own pd_joint_pos -> pd_ee_delta_pose converter uses current * goal^-1 likewise.
        rel = Pose.create_from_pq(q=current.q) * Pose.create_from_pq(q=goal_q).inv()
        rot = matrix_to_euler_angles(quaternion_to_matrix(rel.q), "XYZ")[0].cpu().numpy()
        return np.concatenate([np.asarray(goal.p) - current.p[0].cpu().numpy(), rot])
