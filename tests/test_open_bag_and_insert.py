"""OpenBagAndInsert (`tasks.cloth.open_bag_and_insert`): the bag's mouth needs holding open. A cube dropped onto the
bag as it lies (nobody holding it) stays out of it, wherever over the bag it falls."""

import pytest
import torch

from mani_skill.utils.structs.pose import Pose

import maniladder_ms
from maniladder_ms.deformables import bag
from maniladder_ms.solvers.control import hold_action

DROP_HEIGHT = 0.1  # m: the cube's centre when let fall
SETTLE_STEPS = 40  # control steps the cube and the bag get to come to rest


@pytest.fixture(scope="module")
def env():
    env = maniladder_ms.make("OpenBagAndInsert", obs_mode="state", control_mode="pd_ee_delta_pose")
    yield env
    env.close()


@pytest.mark.parametrize("depth", [0.05, 0.01])  # m past the mouth: over the bag's middle; at the mouth's lip
def test_cube_dropped_on_the_unheld_bag_stays_out(env, depth):
    env.reset(seed=0)
    task = env.unwrapped
    frame = bag.bag_frame(task.bag.positions(), task.bag.layout)
    drop = frame["centre"] + frame["u"] * (frame["mouth"] - depth)[:, None]
    drop[:, 2] = DROP_HEIGHT
    task.cube.set_pose(Pose.create_from_pq(drop))
    task.cube.set_linear_velocity(torch.zeros(1, 3))
    hold = hold_action(task.agent)
    for _ in range(SETTLE_STEPS):
        info = env.step(hold)[-1]
    # the cube came to rest on the bag, not beside it: the test drops it where the bag is
    assert float(task.cube.pose.p[0, 2]) > task.cube_half + task.cloth_config.radius, task.cube.pose.p
    assert not bool(info["cube_inside"][0]) and not bool(info["success"][0]), info
