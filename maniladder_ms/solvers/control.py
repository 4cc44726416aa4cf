"""The control layer of the scripted solvers: motion helpers for the ManiLadder agents, vectorised over the env's
parallel sub-scenes (`DrivenSolver` in `driven.py` builds the solvers' moves on `Driver`).

Everything here builds flat action tensors (num_envs, action_dim) for the agent's current control
mode from per-part targets, so the same helpers drive every embodiment:

- `hold_action(agent, qpos)`: the action that holds `qpos` (default: the current joint targets), in any mode.
- `Driver(env)`: closed-loop TCP moves through `pd_ee_delta_pose` (ManiSkill's IK controller) for
  each arm, gripper open/close, LEAP hand postures (`postures.LEAP_SYNERGIES`), base velocity.
"""

from __future__ import annotations

import numpy as np
import torch

from mani_skill.agents.controllers.pd_base_vel import PDBaseVelController
from mani_skill.agents.controllers.pd_ee_pose import PDEEPosController
from mani_skill.agents.controllers.pd_joint_pos import PDJointPosMimicController
from mani_skill.agents.controllers.pd_joint_pos_vel import PDJointPosVelController
from mani_skill.agents.controllers.pd_joint_vel import PDJointVelController
from mani_skill.utils.structs.pose import Pose
from mani_skill.utils.geometry.rotation_conversions import (
    axis_angle_to_matrix,
    matrix_to_axis_angle,
    matrix_to_euler_angles,
    quaternion_to_matrix,
)

from maniladder_ms.geometry import wrap_angle
from maniladder_ms.solvers.postures import LEAP_SYNERGIES


def _controllers(agent) -> dict:
    return agent.controller.controllers


def hold_action(agent, qpos: torch.Tensor | None = None) -> torch.Tensor:
    """Flat action (num_envs, dim) holding joint positions `qpos` (default: `current_joint_targets`), in any of
    the agent's control modes: delta, velocity and base parts send zeros, joint-target parts the targets (and
    zero velocities), and an absolute TCP-pose part (`pd_ee_pose`) the current TCP pose (so there it holds the
    current state only: another `qpos` is refused)."""
    if qpos is not None and any(_is_absolute_pose(c) for c in _controllers(agent).values()):
        raise ValueError("hold_action in an absolute TCP-pose mode holds the current pose: call it without qpos")
    if qpos is None:
        qpos = current_joint_targets(agent)
    parts = []
    for ctrl in _controllers(agent).values():
        n = ctrl.single_action_space.shape[0]
        zeros = torch.zeros(qpos.shape[0], n, device=qpos.device)
        if _is_absolute_pose(ctrl):
            pose = ctrl.ee_pose_at_base  # the controller's frame: the articulation root
            parts.append(torch.cat([pose.p, matrix_to_euler_angles(quaternion_to_matrix(pose.q), "XYZ")], dim=1))
        elif isinstance(ctrl, (PDBaseVelController, PDJointVelController, PDEEPosController)) or \
                getattr(ctrl.config, "use_delta", False):
            parts.append(zeros)  # velocity and delta controllers hold with a zero action
        elif isinstance(ctrl, PDJointPosVelController):
            parts.append(torch.cat([_joint_action(ctrl, qpos), zeros[:, n // 2:]], dim=1))  # targets, zero velocity
        else:
            parts.append(_joint_action(ctrl, qpos))
    return torch.cat(parts, dim=1).float()


def current_joint_targets(agent) -> torch.Tensor:
    """The joint targets the agent's controllers hold (num_envs, dof): each joint-target controller's own target
    (ManiSkill sets it to the joint positions at reset, before the first action writes the drives; the drives
    read 0 until then), the drive targets for the other joints."""
    qpos = agent.robot.get_drive_targets().clone()
    for ctrl in _controllers(agent).values():
        target = getattr(ctrl, "_target_qpos", None)
        if target is not None:
            qpos[:, ctrl.active_joint_indices] = target
    return qpos


def _is_absolute_pose(ctrl) -> bool:
    return isinstance(ctrl, PDEEPosController) and not ctrl.config.use_delta


def _joint_action(ctrl, qpos: torch.Tensor) -> torch.Tensor:
    """Action of an absolute joint-position controller (mimic: its first joint) that targets `qpos`."""
    idx = ctrl.active_joint_indices
    q = qpos[:, idx[:1]] if isinstance(ctrl, PDJointPosMimicController) else qpos[:, idx]
    if ctrl.config.normalize_action:  # invert ManiSkill's [-1, 1] -> [lower, upper] map
        low, high = float(np.min(ctrl.config.lower)), float(np.max(ctrl.config.upper))
        q = 2 * (q - low) / (high - low) - 1
    return q.float()


def _pose_error(cur_p, cur_q, tgt_p, tgt_q):
    """Position error and axis-angle rotation error (world frame), batched."""
    rc, rt = quaternion_to_matrix(cur_q), quaternion_to_matrix(tgt_q)
    return tgt_p - cur_p, matrix_to_axis_angle(rt @ rc.transpose(-1, -2))


class Driver:
    """Drive an env whose agent is in `pd_ee_delta_pose` (any ManiLadder agent) with simple motions.

    Arm parts are the controllers named `arm` / `<side>_arm`; the end effector part right after each
    arm is its gripper / hand. Targets are world-frame TCP poses (p (n,3), q (n,4) wxyz tensors).
    """

    def __init__(self, env, pos_gain: float = 1.0, rot_gain: float = 1.0):
        self.env = env
        self.base = env.unwrapped
        if self.base.control_mode != "pd_ee_delta_pose":
            raise ValueError(f"Driver needs control_mode='pd_ee_delta_pose', not {self.base.control_mode!r}")
        self.agent = self.base.agent
        ctrls = _controllers(self.agent)
        self.names = list(ctrls)
        self.slices, start = {}, 0
        for name, c in ctrls.items():
            n = c.single_action_space.shape[0]
            self.slices[name] = slice(start, start + n)
            start += n
        self.dim = start
        self.pos_gain, self.rot_gain = pos_gain, rot_gain
        self.ee_cmd = {}  # last gripper / hand command per part
        self.arm_targets = {}  # last world TCP target (p, q) per arm
        for name, c in ctrls.items():
            if not name.endswith("arm") and not isinstance(c, PDBaseVelController):
                self.ee_cmd[name] = hold_action_part(self.agent, c)
        self.last = None

    def arm_names(self):
        return [n for n in self.names if n.endswith("arm")]

    def tcp(self, arm: str = "arm"):
        return _controllers(self.agent)[arm].ee_pose  # world pose of the IK end link, batched

    def _arm_action(self, arm, tgt_p, tgt_q):
        ctrl = _controllers(self.agent)[arm]
        cur = ctrl.ee_pose
        dp, dr = _pose_error(cur.p, cur.q, tgt_p, tgt_q)
        # into the controller's frame (root-aligned); the root's rotation is the robot's world rotation
        root_r = quaternion_to_matrix(self.agent.robot.pose.q)
        dp = (root_r.transpose(-1, -2) @ dp.unsqueeze(-1)).squeeze(-1)
        dr = (root_r.transpose(-1, -2) @ dr.unsqueeze(-1)).squeeze(-1)
        err_r = dr.norm(dim=1)
        # the controller reads [3:6] as XYZ Euler angles of the rotation delta; ManiSkill 3.0.1 scales
        # them by rot_lower (-0.1), so +1 turns by -0.1 rad: send the negated, limited Euler delta
        step = dr * (self.rot_gain * torch.clamp(0.1 / err_r.clamp(min=1e-9), max=1.0)).unsqueeze(1)
        euler = matrix_to_euler_angles(axis_angle_to_matrix(step), "XYZ")
        a = torch.cat([(dp * self.pos_gain / 0.1).clamp(-1, 1), -euler / 0.1], dim=1)
        return a, dp.norm(dim=1), err_r

    def step(self, targets: dict | None = None, base_vel=None):
        """One control step; `targets` maps arm part name -> (p, q) world TCP target.

        Arms without a new target keep servoing to their last one: a zero delta would instead accept
        wherever contact (a closing hand on the table, a held weight) has pushed the TCP.
        """
        n = self.base.num_envs
        action = torch.zeros(n, self.dim, device=self.base.device)
        self.arm_targets.update(targets or {})
        errs = {}
        for arm in self.arm_names():
            if arm in self.arm_targets:
                a, ep, er = self._arm_action(arm, *self.arm_targets[arm])
                action[:, self.slices[arm]] = a
                errs[arm] = (ep, er)
        for name, cmd in self.ee_cmd.items():
            action[:, self.slices[name]] = cmd
        if base_vel is not None and "base" in self.slices:
            action[:, self.slices["base"]] = torch.as_tensor(base_vel, dtype=torch.float32, device=self.base.device)
        self.last = self.env.step(action)
        return errs

    def move(self, targets, max_steps: int = 60, pos_tol: float = 0.005, rot_tol: float = 0.03):
        """Step towards world TCP targets {arm: (p, q)} until all are within tolerance (or max_steps).
        `targets` may be a function returning them, called once a control step (targets that track a
        moving object, or a hold that corrects them step by step)."""
        for _ in range(max_steps):
            errs = self.step(targets() if callable(targets) else targets)
            if all(bool((ep < pos_tol).all() and (er < rot_tol).all()) for ep, er in errs.values()):
                break
        return self.last

    def set_ee(self, part: str, command, steps: int = 10):
        """Set a gripper command (normalised) or LEAP joint targets / synergy name; hold `steps` steps."""
        if isinstance(command, str):
            command = LEAP_SYNERGIES[command]
        cmd = torch.as_tensor(command, dtype=torch.float32, device=self.base.device)
        self.ee_cmd[part] = cmd.reshape(-1, cmd.shape[-1]).expand(self.base.num_envs, -1).clone()
        for _ in range(steps):
            self.step()
        return self.last

    def close_hand(self, part: str = "hand", synergy="power", ramp_steps: int = 40, hold_steps: int = 8,
                   arm_targets=None):
        """Move LEAP joint targets from the current command to a synergy (a name, or 16 joint targets)
        linearly, then hold. `arm_targets`: a function returning {arm: (p, q)}, called once a control step
        (an arm held in place by a correction while its hand closes; None: the arms keep their targets).

        The slow ramp (2 s) lets fingers and thumb reach the object together; faster closing pushes a
        small object out (a 5 cm cube: 19/20 seeds lifted at 40 steps, 17/20 at 25).
        """
        if isinstance(synergy, str):
            synergy = LEAP_SYNERGIES[synergy]
        start, goal = self.ee_cmd[part].clone(), torch.as_tensor(np.asarray(synergy), dtype=torch.float32,
                                                                  device=self.base.device)
        for k in range(1, ramp_steps + 1):
            self.set_ee(part, start + (goal - start) * k / ramp_steps, steps=0)
            self.step(arm_targets() if arm_targets else None)
        self.set_ee(part, goal.expand_as(start), steps=0)
        for _ in range(hold_steps):
            self.step(arm_targets() if arm_targets else None)
        return self.last

    def grip(self, closed: bool, part: str = "gripper", steps: int = 10):
        """Close (-1) or open (+1) a parallel gripper (normalised command)."""
        return self.set_ee(part, [-1.0 if closed else 1.0], steps)

    def drive(self, vel, steps: int):
        """Normalised base velocity (vx, vy, wz in [-1, 1]) for `steps` control steps, arm holding."""
        for _ in range(steps):
            self.step(base_vel=vel)
        return self.last


def hold_action_part(agent, ctrl) -> torch.Tensor:
    return _joint_action(ctrl, agent.robot.get_qpos())


def top_down_quat(yaw, n: int, device=None) -> torch.Tensor:
    """wxyz quaternions of a TCP pointing straight down (z down), its x axis at `yaw` about world z."""
    yaw = torch.as_tensor(yaw, dtype=torch.float32, device=device).reshape(-1).expand(n)
    # R = Rz(yaw) * Rx(pi): q = (cos(y/2), 0, 0, sin(y/2)) * (0, 1, 0, 0)
    c, s = torch.cos(yaw / 2), torch.sin(yaw / 2)
    return torch.stack([torch.zeros_like(c), c, s, torch.zeros_like(c)], dim=1)


def drive_base_to(driver: Driver, target, max_steps: int = 200, pos_tol: float = 0.005, yaw_tol: float = 0.01,
                  gain: float = 3.0, speed: float = 1.0):
    """Drive a holonomic base (`ml_tidybot`) to base joint values (x, y, yaw) with a P controller, at most
    `speed` of the base's top speed (a fraction of 0.5 m/s, 1.57 rad/s).

    The arm rides along: its TCP target (the driver's last one, else where the TCP is now) is kept fixed in
    the base's frame, re-expressed in the world at every step from the base's pose then. (A world-fixed
    target, the Driver's default, would have the arm reach back for it as the base drives away; the IK
    solves from the current base joints, so the target at the current base pose leaves the arm joints as
    they are.)"""
    agent, base = driver.agent, driver.base
    target = torch.as_tensor(target, dtype=torch.float32, device=base.device).reshape(-1, 3)
    ctrl = _controllers(agent)["base"]
    vmax = torch.as_tensor(np.asarray(ctrl.config.upper, dtype=np.float32), device=base.device)
    riding = {}  # arm -> its TCP target in the base link's frame
    for arm in driver.arm_names():
        p, q = driver.arm_targets.get(arm, (driver.tcp(arm).p, driver.tcp(arm).q))
        riding[arm] = agent.base_link.pose.inv() * Pose.create_from_pq(p, q)

    def step(vel):
        for arm, rel in riding.items():
            world = agent.base_link.pose * rel
            driver.arm_targets[arm] = (world.p, world.q)
        driver.step(base_vel=vel)

    for _ in range(max_steps):
        q = agent.robot.get_qpos()[:, :3]
        err = target - q
        err[:, 2] = wrap_angle(err[:, 2])
        if bool((err[:, :2].norm(dim=1) < pos_tol).all() and (err[:, 2].abs() < yaw_tol).all()):
            break
        c, s = torch.cos(q[:, 2]), torch.sin(q[:, 2])
        # world error -> base frame (the controller turns base-frame velocities back into the world)
        ex, ey = c * err[:, 0] + s * err[:, 1], -s * err[:, 0] + c * err[:, 1]
        vel = torch.stack([ex, ey, err[:, 2]], dim=1) * gain / vmax
        step(vel.clamp(-speed, speed))
    # settle with zero velocity
    for _ in range(5):
        step(torch.zeros(base.num_envs, 3, device=base.device))
    return driver.last
