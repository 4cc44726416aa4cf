"""ManiSkill's control modes on every ManiLadder agent (docs/control-modes.md), checked on one task of each agent:
every offered mode builds, its action space is the documented layout and the controllers' own, random actions
step and the idle action (`hold_action`) keeps the robot still; per arm, `pd_ee_delta_pos` moves the TCP the
commanded way and `pd_ee_pose` reaches a commanded TCP pose (both in the robot's root frame); a mode an agent
lacks is refused with the modes it offers; the per-arm config builder is ManiSkill's Panda's."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from mani_skill.agents.robots.panda.panda import Panda
from mani_skill.utils.geometry.rotation_conversions import matrix_to_axis_angle, quaternion_to_matrix

import maniladder_ms
from maniladder_ms.agents import AGENT_UIDS
from maniladder_ms.agents.robots import CONTROL_MODES, arm_configs, offered_control_modes
from maniladder_ms import UnsupportedControlModeError
from maniladder_ms.solvers.control import hold_action

TASK_OF_AGENT = {  # a cheap task of each agent
    "ml_panda": "PickPlacePen",
    "ml_panda_leap": "PressButtonHand",
    "ml_dual_panda": "HandoverCube",
    "ml_dual_panda_leap": "LiftBasketHands",
    "ml_tidybot": "MobileFetchMug",
}
ARM = None  # an arm part: its width depends on the mode (ARM_DIMS)
ARM_DIMS = {
    "pd_joint_pos": 7, "pd_joint_delta_pos": 7, "pd_joint_target_delta_pos": 7, "pd_joint_vel": 7,
    "pd_joint_pos_vel": 14, "pd_joint_delta_pos_vel": 14,
    "pd_ee_delta_pos": 3, "pd_ee_target_delta_pos": 3,
    "pd_ee_delta_pose": 6, "pd_ee_target_delta_pose": 6, "pd_ee_pose": 6,
}
PARTS = {  # the action's parts in order, as docs/control-modes.md lays them out
    "ml_panda": [("arm", ARM), ("gripper", 1)],
    "ml_panda_leap": [("arm", ARM), ("hand", 16)],
    "ml_dual_panda": [("left_arm", ARM), ("left_gripper", 1), ("right_arm", ARM), ("right_gripper", 1)],
    "ml_dual_panda_leap": [("left_arm", ARM), ("left_hand", 16), ("right_arm", ARM), ("right_hand", 16)],
    "ml_tidybot": [("base", 3), ("arm", ARM), ("gripper", 1)],
}
MODE_CASES = [(uid, mode) for uid in AGENT_UIDS for mode in offered_control_modes(uid)]


def make(uid: str, mode: str):
    """The agent's task in `mode`, reset (the scene gym.make built: a seeded reset does not rebuild it)."""
    spec = maniladder_ms.default_catalog().get(TASK_OF_AGENT[uid])
    env = gym.make(spec.env_id, obs_mode="state", control_mode=mode, fresh_physics_per_seed=False)
    env.reset(seed=0)
    assert env.unwrapped.agent.uid == uid
    return env


def slices(agent) -> dict:
    out, start = {}, 0
    for name, ctrl in agent.controller.controllers.items():
        n = ctrl.single_action_space.shape[0]
        out[name], start = slice(start, start + n), start + n
    return out


def arms(agent) -> list:
    return [name for name in agent.controller.controllers if name.endswith("arm")]


def test_every_agent_offers_maniskills_panda_modes():
    for uid in AGENT_UIDS:
        assert set(offered_control_modes(uid)) == set(CONTROL_MODES), uid
    # the default (first) modes are what they were: pd_joint_pos on our agents, ManiSkill's own on ml_panda
    assert {offered_control_modes(uid)[0] for uid in AGENT_UIDS if uid != "ml_panda"} == {"pd_joint_pos"}
    assert offered_control_modes("ml_panda")[0] == "pd_joint_delta_pos"


def test_arm_builder_is_maniskills_panda():
    """Each mode's arm part is the config ManiSkill's Panda builds (gains, bounds, frames)."""
    panda = object.__new__(Panda)._controller_configs
    ours = arm_configs(Panda.arm_joint_names, Panda.ee_link_name, Panda.urdf_path)
    assert set(ours) == set(panda)
    for mode, parts in panda.items():
        assert ours[mode] == parts["arm"], mode


@pytest.mark.parametrize("uid,mode", MODE_CASES)
def test_mode_builds_steps_and_holds(uid, mode):
    env = make(uid, mode)
    try:
        agent = env.unwrapped.agent
        assert tuple(agent.supported_control_modes) == offered_control_modes(uid)
        ctrls = agent.controller.controllers
        expected = [(name, ARM_DIMS[mode] if dim is ARM else dim) for name, dim in PARTS[uid]]
        assert [(name, c.single_action_space.shape[0]) for name, c in ctrls.items()] == expected
        # the env's action space is the controllers' spaces, concatenated in order
        low = np.concatenate([c.single_action_space.low for c in ctrls.values()])
        high = np.concatenate([c.single_action_space.high for c in ctrls.values()])
        assert env.action_space.shape == (sum(d for _, d in expected),)
        np.testing.assert_array_equal(env.action_space.low, low)
        np.testing.assert_array_equal(env.action_space.high, high)
        # the hand / gripper / base part is the same controller in every mode
        default = agent._controller_configs["pd_joint_pos"]
        for name, ctrl in ctrls.items():
            if not name.endswith("arm"):
                assert ctrl.config == default[name], (mode, name)
        # the idle action holds the robot where it is
        q0 = agent.robot.get_qpos().clone()
        for _ in range(5):
            env.step(hold_action(agent))
        assert (agent.robot.get_qpos() - q0).abs().max().item() < 1e-4
        # random actions run, and move it
        env.action_space.seed(0)
        for _ in range(5):
            obs, *_ = env.step(env.action_space.sample())
        assert torch.isfinite(obs).all()
        assert (agent.robot.get_qpos() - q0).abs().max().item() > 1e-3
    finally:
        env.close()


@pytest.mark.parametrize("uid", AGENT_UIDS)
def test_ee_delta_pos_moves_each_tcp_as_commanded(uid):
    """+x, +y, +z on one arm move its TCP that way in the root frame (0.5 = 5 cm a step asked, 3 steps); the
    other arm stays."""
    env = make(uid, "pd_ee_delta_pos")
    try:
        agent = env.unwrapped.agent
        ctrls, parts = agent.controller.controllers, slices(agent)
        for arm in arms(agent):
            for axis in range(3):
                for _ in range(3):  # settle
                    env.step(hold_action(agent))
                start = {a: ctrls[a].ee_pose_at_base.p.clone() for a in arms(agent)}
                for _ in range(3):
                    action = hold_action(agent)
                    action[:, parts[arm].start + axis] = 0.5
                    env.step(action)
                moved = (ctrls[arm].ee_pose_at_base.p - start[arm])[0]
                off_axis = moved[[i for i in range(3) if i != axis]].abs().max()
                assert moved[axis] > 0.03 and off_axis < 0.2 * moved[axis], (arm, "xyz"[axis], moved.tolist())
                for other in set(arms(agent)) - {arm}:
                    assert (ctrls[other].ee_pose_at_base.p - start[other]).norm() < 2e-3, (arm, other)
    finally:
        env.close()


@pytest.mark.parametrize("uid", AGENT_UIDS)
def test_ee_pose_reaches_a_commanded_tcp_pose(uid):
    """`pd_ee_pose` takes [x, y, z, XYZ Euler angles] of the TCP in the root frame: 5 cm up and 3 cm back from
    the current pose is reached within 5 mm, the orientation kept, each arm in turn."""
    env = make(uid, "pd_ee_pose")
    try:
        agent = env.unwrapped.agent
        ctrls, parts = agent.controller.controllers, slices(agent)
        with pytest.raises(ValueError, match="current pose"):
            hold_action(agent, agent.robot.get_qpos())
        for arm in arms(agent):
            start = ctrls[arm].ee_pose_at_base
            action = hold_action(agent)
            action[:, parts[arm].start] -= 0.03
            action[:, parts[arm].start + 2] += 0.05
            target = action[:, parts[arm]][:, :3].clone()
            for _ in range(10):
                env.step(action)
            pose = ctrls[arm].ee_pose_at_base
            assert (pose.p - target).norm().item() < 5e-3, (arm, pose.p.tolist(), target.tolist())
            turned = matrix_to_axis_angle(quaternion_to_matrix(pose.q) @ quaternion_to_matrix(start.q).transpose(-1, -2))
            assert turned.norm().item() < 0.02, (arm, turned.tolist())
    finally:
        env.close()


def test_ee_delta_pose_rotation_turns_the_other_way():
    """ManiSkill 3.0.1 scales a `pd_ee_delta_pose` rotation command by its lower bound (-0.1), so +1 about an
    axis turns the TCP by -0.1 rad about that root axis (docs/control-modes.md); the translation is +0.1 m."""
    env = make("ml_panda_leap", "pd_ee_delta_pose")
    try:
        agent = env.unwrapped.agent
        ctrl = agent.controller.controllers["arm"]
        for axis in range(3):
            start = quaternion_to_matrix(ctrl.ee_pose_at_base.q)
            action = hold_action(agent)
            action[:, 3 + axis] = 0.5
            env.step(action)
            for _ in range(3):
                env.step(hold_action(agent))
            turned = matrix_to_axis_angle(quaternion_to_matrix(ctrl.ee_pose_at_base.q) @ start.transpose(-1, -2))[0]
            assert turned[axis] < -0.01 and turned.abs().max() == -turned[axis], ("xyz"[axis], turned.tolist())
    finally:
        env.close()


@pytest.mark.parametrize("uid", AGENT_UIDS)
def test_a_mode_the_agent_lacks_is_refused_with_the_modes_it_offers(uid):
    task = TASK_OF_AGENT[uid]
    with pytest.raises(UnsupportedControlModeError) as err:
        gym.make(maniladder_ms.default_catalog().get(task).env_id, obs_mode="state", control_mode="pd_ee_delta_pose_align")
    message = str(err.value)
    assert task in message and uid in message and "'pd_ee_delta_pose_align'" in message
    assert message.endswith("it offers: " + ", ".join(offered_control_modes(uid)))
