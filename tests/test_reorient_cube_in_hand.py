"""ReorientCubeInHand (`tasks.rigid.reorient_cube_in_hand`): the rule's in-hand guard. A marked face brought up by
the wrist with the cube fixed in the hand, or by a roll on the table, is not an in-hand turn; the same face-up cube
turned in the hand is."""

import numpy as np
import sapien
import torch

from mani_skill.utils.geometry.rotation_conversions import axis_angle_to_quaternion
from mani_skill.utils.structs.pose import Pose

import maniladder_ms
from maniladder_ms.tasks.rigid.reorient_cube_in_hand import CUBE_ON_PALM

# the quarter turn the solver's tip gives, in the hand's frame: about the palm's y axis, the marked face (towards the
# fingertips, +x) to the palm normal (+z)
TIP = torch.tensor([[0.0, -np.pi / 2, 0.0]])


def _make():
    return maniladder_ms.make("ReorientCubeInHand", obs_mode="state", control_mode="pd_ee_delta_pose")


def _hold(env, steps: int):
    info = None
    for _ in range(steps):
        *_, info = env.step(torch.zeros(env.action_space.shape))
    return info


def _cube_in_hand(task, turn: torch.Tensor):
    """Put the cube on the palm, turned by the axis-angle `turn` (hand frame) from its start orientation."""
    in_hand = Pose.create_from_pq(torch.tensor([CUBE_ON_PALM]), axis_angle_to_quaternion(turn))
    task.cube.set_pose(task.ee.tcp() * in_hand)
    task.cube.set_linear_velocity(torch.zeros(1, 3))
    task.cube.set_angular_velocity(torch.zeros(1, 3))


def test_the_wrist_turning_the_cube_with_it_is_no_in_hand_turn():
    """The arm turns the hand fingers-up (a wrist turn that brings a face pointing along the fingers up; the arm's
    joints by IK) with the cube carried along rigidly: the marked face is up, but its normal has not moved in the
    hand."""
    env = _make()
    try:
        env.reset(seed=0)
        task = env.unwrapped
        robot = task.agent.robot
        rel = task.ee.tcp().inv() * task.cube.pose  # the cube in the hand's frame
        # half a turn about (x + z): the fingers (and the marked face) up, the palm facing away from the robot
        turn = Pose.create_from_pq(q=axis_angle_to_quaternion(torch.tensor([[1.0, 0.0, 1.0]]) * np.pi / np.sqrt(2)))
        tcp = task.ee.tcp()
        goal = robot.pose.inv() * Pose.create_from_pq(tcp.p, (turn * tcp).q)  # in the robot's base frame
        articulation = robot._objs[0]
        model = articulation.create_pinocchio_model()
        link = [link.name for link in articulation.get_links()].index(task.agent.tcp._objs[0].name)
        mask = np.zeros(articulation.dof, dtype=int)
        mask[:7] = 1
        rng = np.random.default_rng(0)
        limits = np.array([joint.get_limits()[0] for joint in articulation.get_active_joints()[:7]])
        for _ in range(100):
            start = robot.get_qpos()[0].numpy().copy()
            start[:7] = rng.uniform(limits[:, 0], limits[:, 1])
            qpos, ok, _ = model.compute_inverse_kinematics(link, sapien.Pose(goal.p[0].numpy(), goal.q[0].numpy()),
                                                          initial_qpos=start, active_qmask=mask, max_iterations=500)
            if ok:
                break
        assert ok
        robot.set_qpos(torch.as_tensor(qpos, dtype=torch.float32)[None])
        task.cube.set_pose(task.ee.tcp() * rel)
        info = task.evaluate()
        assert bool(info["face_up"][0])
        assert float(info["hand_turn"][0]) < 1.0
        assert not bool(info["turned_in_hand"][0]) and not bool(info["success"][0])
    finally:
        env.close()


def test_a_cube_turned_on_the_table_is_no_in_hand_turn_and_one_turned_in_the_hand_is():
    env = _make()
    try:
        # the marked face turned up on the palm, with no table contact: an in-hand turn, held, success
        env.reset(seed=0)
        task = env.unwrapped
        _cube_in_hand(task, TIP)
        info = _hold(env, 5)
        assert bool(info["face_up"][0]) and bool(info["turned_in_hand"][0])
        # the same, but the cube first lay on the table with the marked face up (a roll on the table): the turn in
        # the hand counts from the pose in which it left the table
        env.reset(seed=0)
        task = env.unwrapped
        face_up = axis_angle_to_quaternion(torch.tensor([[0.0, -np.pi / 2, 0.0]]))
        task.cube.set_pose(Pose.create_from_pq(torch.tensor([[-0.1, 0.0, task.cube_half]]), face_up))
        info = _hold(env, 3)
        assert bool(info["on_table"][0])
        _cube_in_hand(task, TIP)
        info = _hold(env, 5)
        assert bool(info["face_up"][0]) and not bool(info["on_table"][0])
        assert not bool(info["turned_in_hand"][0]) and not bool(info["success"][0])
    finally:
        env.close()
