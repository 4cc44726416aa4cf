"""Demo frames to cached encoder features: the images a visual policy trains on, rendered once.

Each demo step's recorded env state is restored and only the policy's cameras are rendered (the images
it sees at evaluation: the obs before the step's action); the frozen encoder turns them into tokens,
stored per episode as float16 (`cache_features`), so training never renders or encodes again.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator, Optional, Sequence

import numpy as np
import torch

from maniladder_ms.demos.files import load_demo_json, replay_env_kwargs
from maniladder_ms.demos.frames import replay_frames
from maniladder_ms.demos.joint_targets import TARGET_MODE, joint_target_episodes

from .encoders import Encoder


def demo_frames(h5_path, cameras: Sequence[str], size: int = 128, progress: bool = False,
                stride: int = 1) -> Iterator[tuple]:
    """Per episode of a demo file: (images uint8 (F, cameras, size, size, 3) of the frames 0, stride, 2 stride,
    ..., their step indices (F,), all actions (T, A), episode json); rendered by `demos.frames.replay_frames`."""
    for e in replay_frames(h5_path, cameras, size, progress, stride):
        yield e.images, e.frames, e.actions, e.ep


def encode_frames(encoder: Encoder, images: np.ndarray) -> torch.Tensor:
    """(T, cameras, H, W, 3) uint8 -> (T, cameras * tokens, dim) features, cameras in order."""
    T, C = images.shape[:2]
    tokens = encoder.encode(images.reshape(T * C, *images.shape[2:]))  # (T*C, tokens, dim)
    return tokens.reshape(T, C * tokens.shape[1], tokens.shape[2])


def cache_features(h5_path, encoder: Encoder, cameras: Sequence[str], out: Path, size: int = 128,
                   progress: bool = False, stride: int = 1, control_mode: Optional[str] = None) -> Path:
    """Render and encode every episode of a demo file into `out` (.npz: features_<i> float16 of the frames
    frames_<i> (every `stride`-th step), all actions_<i>, seeds, control_mode); an existing file is kept (delete
    it to recompute). `control_mode`: the mode of the stored actions, None for the recorded one, or
    "pd_joint_pos" (absolute joint targets, converted by `demos.joint_targets`)."""
    out = Path(out)
    if out.exists():
        return out
    recorded = replay_env_kwargs(load_demo_json(Path(h5_path))).get("control_mode")
    converted = None
    if control_mode not in (None, recorded):
        if control_mode != TARGET_MODE:
            raise ValueError(f"actions convert to {TARGET_MODE} only, not {control_mode!r}")
        converted = joint_target_episodes(h5_path, progress=progress)
    arrays, seeds = {}, []
    for i, (images, frames, actions, ep) in enumerate(demo_frames(h5_path, cameras, size, progress, stride)):
        if converted is not None:
            actions, replayed, conv_ep = next(converted)
            if conv_ep["episode_id"] != ep["episode_id"] or not replayed:
                raise RuntimeError(f"{h5_path}: episode {ep['episode_id']} no longer succeeds when replayed for its "
                                   "joint targets; re-record the demos")
        arrays[f"features_{i}"] = encode_frames(encoder, images).numpy().astype(np.float16)
        arrays[f"frames_{i}"] = frames
        arrays[f"actions_{i}"] = actions
        seeds.append(ep["episode_seed"])
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_suffix(".partial.npz")
    np.savez(partial, seeds=np.asarray(seeds), encoder=np.asarray(encoder.name), cameras=np.asarray(list(cameras)),
             control_mode=np.asarray(control_mode or recorded or ""), **arrays)
    partial.replace(out)  # complete files only: an interrupted run recomputes
    return out


def load_features(path) -> list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]]:
    """The episodes of a feature cache as (features (F, n_obs, dim) float32, actions (T, A), frames (F,)):
    features_[k] is the observation before actions[frames[k]]."""
    data = np.load(Path(path))
    n = len(data["seeds"])
    out = []
    for i in range(n):
        feats = torch.from_numpy(data[f"features_{i}"].astype(np.float32))
        frames = data[f"frames_{i}"] if f"frames_{i}" in data else np.arange(len(feats))
        out.append((feats, torch.from_numpy(data[f"actions_{i}"]), torch.from_numpy(np.asarray(frames, np.int64))))
    return out
