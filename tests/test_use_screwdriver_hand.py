"""UseScrewdriverHand (`tasks.articulated.use_screwdriver_hand`): the rule counts only a turn the hand drives through
the screwdriver. A screw turned by other means (its joint set, a screwdriver in the slot that no hand holds) does
not count; the solver's turn does, and its success ends as soon as the tip leaves the slot."""

import numpy as np
import torch

from mani_skill.utils.structs.pose import Pose

import maniladder_ms
from maniladder_ms.solvers import solver_for
from maniladder_ms.tasks.articulated.use_screwdriver_hand import TIP_Z


def _make():
    return maniladder_ms.make("UseScrewdriverHand", obs_mode="state", control_mode="pd_ee_delta_pose")


def _still(env):
    return env.step(torch.zeros(env.action_space.shape))[-1]


def _screwdriver_in_slot(task, depth: float):
    """Stand the (unheld) screwdriver upright with its tip `depth` below the head's top, blade along a slot arm."""
    tip = task.head_top() - torch.tensor([[0.0, 0.0, depth]])
    task.screwdriver.set_pose(Pose.create_from_pq(tip - torch.tensor([[0.0, 0.0, TIP_Z]]), task.screw.pose.q))
    task.screwdriver.set_linear_velocity(torch.zeros(1, 3))
    task.screwdriver.set_angular_velocity(torch.zeros(1, 3))


def test_a_screw_turned_without_the_held_screwdriver_does_not_count():
    """The screwdriver stands in the slot, unheld, while the screw is turned a whole turn step by step (its joint
    set): the joint's angle passes `turn_angle`, the tip is in the slot, but no hand holds the tool."""
    env = _make()
    try:
        env.reset(seed=0)
        task = env.unwrapped
        _screwdriver_in_slot(task, 0.005)
        info = _still(env)
        assert bool(info["tip_in_slot"].all()) and not bool(info["screwdriver_held"].any())
        for k in range(1, 21):
            task.screw.set_qpos(torch.tensor([[2 * np.pi * k / 20]]))
            _screwdriver_in_slot(task, 0.005)
            info = _still(env)
        assert float(info["screw_angle"][0]) > np.deg2rad(task.turn_angle)
        assert float(info["tool_turn"][0]) == 0.0
        assert not bool(info["success"].any())
    finally:
        env.close()


def test_the_solver_turn_counts_and_ends_when_the_tip_leaves_the_slot():
    env = _make()
    try:
        info = solver_for("UseScrewdriverHand").run(env, 100)
        task = env.unwrapped
        assert bool(info["success"].all())
        assert abs(float(info["tool_turn"][0])) >= np.deg2rad(task.turn_angle)
        # the same turned screw, the screwdriver lifted 3 cm out of the slot (still in the hand's reach): no success
        task.screwdriver.set_pose(Pose.create_from_pq(task.screwdriver.pose.p + torch.tensor([[0.0, 0.0, 0.03]]),
                                                      task.screwdriver.pose.q))
        info = task.evaluate()
        assert not bool(info["tip_in_slot"].any()) and not bool(info["success"].any())
    finally:
        env.close()
