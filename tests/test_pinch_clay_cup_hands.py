"""PinchClayCupHands (`tasks.clay.pinch_clay_cup_hands`): the one particle read a step (`clay_points`) is the
particles as they are after every physics step, reset and state set, and every reader gets it."""

import torch

import maniladder_ms


def test_clay_points_are_read_again_after_each_step_reset_and_state_set():
    env = maniladder_ms.make("PinchClayCupHands", obs_mode="state", control_mode="pd_ee_delta_pose")
    try:
        env.reset(seed=0)
        task = env.unwrapped
        env.action_space.seed(0)

        def fresh() -> torch.Tensor:
            return task._read_points()  # `Clay.positions` itself, past the cache

        assert torch.equal(task.clay_points(), fresh())
        state, before = task.get_state_dict(), task.clay_points()
        action = torch.zeros(env.action_space.shape)
        action[:3] = 1.0  # the left arm's TCP down and aside: the hands move, the clay settles
        moved = False
        for _ in range(4):
            env.step(action)
            points = task.clay_points()
            assert torch.equal(points, fresh())
            assert task.clay.positions() is points  # the clay's own reads (`relax`) get the same array
            moved |= not torch.equal(points, before)
        assert moved, "the particles moved: a stale read would have shown"
        after = task.clay_points()
        task.set_state_dict(state)
        assert torch.equal(task.clay_points(), fresh()) and torch.equal(task.clay_points(), before)
        assert not torch.equal(task.clay_points(), after)
        env.step(action)
        stepped = task.clay_points()
        env.reset()  # no seed: the same scene, the clay placed again at random
        assert torch.equal(task.clay_points(), fresh()) and not torch.equal(task.clay_points(), stepped)
        env.reset(seed=1)  # a seed: a fresh scene
        assert torch.equal(task.clay_points(), fresh()) and not torch.equal(task.clay_points(), before)
    finally:
        env.close()
