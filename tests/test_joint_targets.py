"""A demo recorded in end-effector deltas, converted to absolute joint targets, replays the same motion."""

from pathlib import Path

import numpy as np
import pytest
import torch

import maniladder_ms
from maniladder_ms.demos.joint_targets import TARGET_MODE, joint_target_episodes

REPO = Path(__file__).resolve().parents[1]
DELTA = "trajectory.none.pd_ee_delta_pose.physx_cpu.h5"


@pytest.mark.parametrize("task", ["LiftWideBox", "LiftBottleHand"])  # two grippers; one LEAP hand (arm + 16 hand joints)
def test_delta_pose_demos_replay_to_success_as_joint_targets(task):
    episodes = list(joint_target_episodes(REPO / "demos" / task / DELTA))
    assert episodes and all(replayed for _, replayed, _ in episodes)
    env = maniladder_ms.make(task, control_mode=TARGET_MODE)
    try:
        for actions, _, ep in episodes:
            assert actions.shape[1] == env.action_space.shape[-1]
            reset_kwargs = dict(ep.get("reset_kwargs") or {})
            reset_kwargs.setdefault("seed", ep["episode_seed"])
            env.reset(**reset_kwargs)
            info = {}
            for a in actions:  # from the seeded reset, in the other control mode
                _, _, _, _, info = env.step(torch.as_tensor(a)[None])
            assert bool(info["success"][0]), f"{task} episode {ep['episode_id']}"
    finally:
        env.close()


def test_joint_target_demos_pass_through_unchanged():
    from maniladder_ms.demos.files import episode_arrays, open_demo_h5

    path = REPO / "demos" / "PickPlacePen" / "trajectory.none.pd_joint_pos.physx_cpu.h5"
    with open_demo_h5(path) as h5:
        for actions, _, ep in joint_target_episodes(path):
            np.testing.assert_array_equal(actions, episode_arrays(h5, ep["episode_id"], str(path))[0])
