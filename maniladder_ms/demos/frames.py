"""Demo frames: camera images and robot proprioception of every recorded step, rendered by restoring the
step's env state (the obs before the step's action), so state-only demos (obs mode `none`) give visual data.

One renderer for every consumer: the visual policy's feature cache (`policy.features.demo_frames`) and the
LeRobot export (`demos.lerobot`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Optional, Sequence

import numpy as np

from .files import episode_arrays, episode_reset_kwargs, load_demo_json, open_demo_h5, replay_env_kwargs, state_at, torch_state


@dataclass
class EpisodeFrames:
    images: np.ndarray  # uint8 (F, cameras, size, size, 3), cameras in the order asked for
    frames: np.ndarray  # (F,) step indices of the images: 0, stride, 2 stride, ...
    actions: np.ndarray  # float32 (T, A): every recorded action, in the recorded control mode
    qpos: np.ndarray  # float32 (F, joints): the robot's joint positions at those frames (all robots, in order)
    qvel: np.ndarray  # float32 (F, joints)
    ep: dict  # the episode's json entry (episode_id, episode_seed, instruction, ...)


def robot_joint_names(base) -> list[str]:
    """Active joint names of the env's robot(s), the order of `EpisodeFrames.qpos`."""
    return [j.name for robot in _robots(base) for j in robot.get_active_joints()]


def _robots(base) -> list:
    agent = base.agent
    return [a.robot for a in agent.agents] if hasattr(agent, "agents") else [agent.robot]


def _proprio(base) -> tuple[np.ndarray, np.ndarray]:
    robots = _robots(base)
    qpos = np.concatenate([r.get_qpos()[0].cpu().numpy() for r in robots])
    qvel = np.concatenate([r.get_qvel()[0].cpu().numpy() for r in robots])
    return qpos.astype(np.float32), qvel.astype(np.float32)


def replay_frames(h5_path, cameras: Optional[Sequence[str]], size: int = 128, progress: bool = False,
                  stride: int = 1, on_env=None) -> Iterator[EpisodeFrames]:
    """Per episode of a demo file, its frames 0, stride, 2 stride, ... rendered from `cameras` (None: all
    the task's cameras, third-view and wrist) at `size` x `size`. `on_env(base_env, cameras)` is called once,
    after the first reset. Unknown cameras raise ValueError naming the task's cameras."""
    from tqdm import tqdm

    import maniladder_ms

    meta = load_demo_json(Path(h5_path))
    env = maniladder_ms.make(meta["task_spec"].id, obs_mode="rgb", cameras=None if cameras is None else tuple(cameras),
                             sensor_configs=dict(width=size, height=size), **replay_env_kwargs(meta))
    base = env.unwrapped
    try:
        with open_demo_h5(Path(h5_path)) as h5:
            for ep in tqdm(meta["episodes"], desc=f"render {Path(h5_path).parent.name}", disable=not progress):
                actions, states = episode_arrays(h5, ep["episode_id"], str(h5_path))
                env.reset(**episode_reset_kwargs(ep))
                if cameras is None:
                    cameras = tuple(base._sensors)
                if on_env is not None:
                    on_env(base, tuple(cameras))
                    on_env = None
                frames = np.arange(0, len(actions), stride)
                images = np.empty((len(frames), len(cameras), size, size, 3), np.uint8)
                qpos, qvel = [], []
                for i, t in enumerate(frames):
                    base.set_state_dict(torch_state(state_at(states, int(t))))
                    obs = base.get_obs(unflattened=True)
                    for c, cam in enumerate(cameras):
                        images[i, c] = obs["sensor_data"][cam]["rgb"][0].cpu().numpy()
                    q, v = _proprio(base)
                    qpos.append(q)
                    qvel.append(v)
                yield EpisodeFrames(images, frames, np.asarray(actions, np.float32), np.stack(qpos), np.stack(qvel), ep)
    finally:
        env.close()
