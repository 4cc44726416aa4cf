"""The UnscrewCap family (`tasks.articulated.unscrew_cap`, `objects.jar`): the thread joint and the rule's held turn."""

import numpy as np
import torch

import maniladder_ms
from maniladder_ms.objects.jar import screw_angle


def test_thread_keeps_its_angle_past_a_turn_and_an_unheld_turn_does_not_count():
    env = maniladder_ms.make("OpenJarBimanual", obs_mode="state", control_mode="pd_ee_delta_pose")
    try:
        env.reset(seed=0)
        task = env.unwrapped
        release = np.deg2rad(task.release_angle)
        hold = torch.zeros(env.action_space.shape)
        # the lid turned past the release angle (more than a full turn) without any end effector on it
        task.jar.set_qpos(torch.full((1, 1), release + 0.2))
        task.jar.set_qvel(torch.zeros(1, 1))
        for _ in range(5):
            *_, info = env.step(hold)
        # the joint is the thread: unwrapped (not folded back into one turn), held still by its friction
        assert abs(float(screw_angle(task.jar)[0]) - (release + 0.2)) < 0.02
        assert float(info["lid_angle"][0]) >= release
        # ... but nothing held the lid and the jar while it turned: no held turn, no success
        assert float(info["held_turn"][0]) == 0.0
        assert not bool(info["success"][0])
        # screwed home is the lower limit: the lid cannot be tightened past it
        task.jar.set_qpos(torch.zeros(1, 1))
        task.jar.set_qvel(torch.full((1, 1), -2.0))
        for _ in range(5):
            env.step(hold)
        assert float(screw_angle(task.jar)[0]) > -0.01
    finally:
        env.close()
