"""The end-effector vocabulary (`agents.effectors`) on every agent, and episode memory (`envs.memory`)."""

import numpy as np
import pytest
import torch

import maniladder_ms
from maniladder_ms.geometry import actor_yaw
from maniladder_ms.agents.effectors import SINGLE
from maniladder_ms.envs.memory import EpisodeMemory

# one built task per agent: (task, expected sides, kind)
AGENT_TASKS = [
    ("PickPlacePen", (SINGLE,), "gripper"),
    ("LiftBottleHand", (SINGLE,), "leap"),
    ("HandoverCube", ("left", "right"), "gripper"),
    ("LiftBasketHands", ("left", "right"), "leap"),
]


@pytest.mark.parametrize("task_id,sides,kind", AGENT_TASKS)
def test_vocabulary_names_the_end_effectors(task_id, sides, kind):
    env = maniladder_ms.make(task_id, obs_mode="state")
    try:
        env.reset(seed=0)
        ee = env.unwrapped.ee
        assert ee.sides == sides and ee.kind == kind
        for side in sides:
            assert ee.tcp(side).p.shape == (1, 3)
            assert ee.is_open(side).tolist() == [True]  # every agent starts open
        table = env.unwrapped.ladder_scene.table
        assert ee.holds(table).tolist() == [False]
        with pytest.raises(KeyError, match="no end effector"):
            ee["middle"]
        if len(sides) > 1:
            with pytest.raises(ValueError, match="name one"):
                ee.tcp()
    finally:
        env.close()


@pytest.mark.parametrize("uid,sides,kind", [
    ("ml_panda", (SINGLE,), "gripper"), ("ml_panda_leap", (SINGLE,), "leap"), ("ml_dual_panda", ("left", "right"), "gripper"),
    ("ml_dual_panda_leap", ("left", "right"), "leap"), ("ml_tidybot", (SINGLE,), "gripper"),
])
def test_every_agent_has_the_vocabulary(uid, sides, kind):
    import gymnasium as gym

    env = gym.make("ManiLadder-AgentGallery-v1", robot_uids=uid, obs_mode="state")
    try:
        env.reset(seed=0)
        ee = env.unwrapped.ee
        assert ee.sides == sides and ee.kind == kind
        assert ee.is_open().tolist() == [True]
        for side in sides:
            assert torch.isfinite(ee.tcp(side).p).all()
    finally:
        env.close()


def test_gripper_holds_what_it_squeezes_and_not_what_it_only_touches():
    """PickPlacePen's solver grasps the pen: held while lifted, not before; touching is not holding."""
    from maniladder_ms.solvers.panda import PandaSolver

    env = maniladder_ms.make("PickPlacePen", obs_mode="state", control_mode="pd_joint_pos")
    try:
        with PandaSolver.episode(env, 100) as robot:
            task = env.unwrapped
            assert not task.ee.holds(task.pen).any()
            pen_p = task.pen.pose.p[0].numpy()
            yaw = robot.closest_grasp_yaw(actor_yaw(task.pen) + np.pi / 2)
            robot.pick(robot.top_down_pose([pen_p[0], pen_p[1], task.pen_radius], yaw))
            assert task.ee.holds(task.pen).all() and task.ee.touches(task.pen).all()
            assert not task.ee.is_open().any()
            # answers are cached until the next physics step: one changed in place leaves the cache as it was
            answer = task.ee.holds(task.pen)
            answer[:] = False
            assert task.ee.holds(task.pen).all()
    finally:
        env.close()


def test_a_reset_scene_has_no_contacts_from_the_previous_episode():
    """PhysX lists the contacts of its last step: after a reset (bodies placed, none stepped) the pen the
    gripper held in the last episode is neither held nor touched, and the reset's observation is a fresh
    env's (it was not: LiftBasketHands' grasp flag at reset came from the step before)."""
    from maniladder_ms.agents.effectors import contact_forces
    from maniladder_ms.solvers.panda import PandaSolver

    env = maniladder_ms.make("PickPlacePen", obs_mode="state", control_mode="pd_joint_pos")
    fresh = maniladder_ms.make("PickPlacePen", obs_mode="state", control_mode="pd_joint_pos")
    try:
        with PandaSolver.episode(env, 100) as robot:
            task = env.unwrapped
            pen_p = task.pen.pose.p[0].numpy()
            yaw = robot.closest_grasp_yaw(actor_yaw(task.pen) + np.pi / 2)
            robot.pick(robot.top_down_pose([pen_p[0], pen_p[1], task.pen_radius], yaw))
            assert task.ee.holds(task.pen).all()
        # the next episode puts the arm back where the pen was taken from: seed 100 again
        obs, info = env.reset(seed=100)
        assert not task.ee.holds(task.pen).any() and not task.ee.touches(task.pen).any()
        assert contact_forces(task.scene, task.pen, task.ee["main"].fingers).abs().sum() == 0
        assert torch.equal(obs, fresh.reset(seed=100)[0])
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        # stepped: the table's contact with the pen counts again
        assert contact_forces(task.scene, task.ladder_scene.table, [task.pen]).norm(dim=-1).sum() > 0
    finally:
        env.close()
        fresh.close()


def test_episode_memory_latches_counts_stores_and_resets():
    memory = EpisodeMemory(num_envs=3, device="cpu")
    memory.flag("handed_over")
    memory.counter("static_steps")
    memory.value("start", dim=2)
    memory.latch("handed_over", torch.tensor([True, False, False]))
    memory.latch("handed_over", torch.tensor([False, False, True]))
    assert memory["handed_over"].tolist() == [True, False, True]  # latched: stays set
    for cond in ([1, 1, 0], [1, 0, 1], [1, 1, 1]):
        memory.count("static_steps", torch.tensor(cond), consecutive=True)
    assert memory["static_steps"].tolist() == [3, 1, 2]
    memory.store("start", torch.tensor([[1.0, 2.0]]), env_idx=torch.tensor([1]))
    assert memory["start"][1].tolist() == [1.0, 2.0] and memory["start"][0].tolist() == [0.0, 0.0]
    memory.reset(torch.tensor([0, 1]))
    assert memory["handed_over"].tolist() == [False, False, True]
    assert memory["static_steps"].tolist() == [0, 0, 2]
    with pytest.raises(KeyError, match="no episode memory field"):
        memory["nope"]
    with pytest.raises(TypeError, match="is a flag"):
        memory.count("handed_over", torch.ones(3))
    with pytest.raises(ValueError, match="declared twice"):
        memory.flag("handed_over")


def test_episode_memory_is_env_state():
    """A memory field rides in get_state_dict / set_state_dict and the flat get_state / set_state."""
    env = maniladder_ms.make("PickPlacePen", obs_mode="state")
    try:
        env.reset(seed=0)
        base = env.unwrapped
        base.memory.flag("probe")
        base.memory.latch("probe", torch.tensor([True]))
        state, flat = base.get_state_dict(), base.get_state()
        assert state["memory_probe"].tolist() == [[1.0]]
        base.memory.reset(torch.tensor([0]))
        base.set_state_dict(state)
        assert base.memory["probe"].tolist() == [True]
        base.memory.reset(torch.tensor([0]))
        base.set_state(flat)
        assert base.memory["probe"].tolist() == [True]
    finally:
        env.close()
