"""Demo frames to cached encoder features: the images a visual policy trains on, rendered once.

Each demo step's recorded env state is restored and only the policy's cameras are rendered (the images
it sees at evaluation: the obs before the step's action); the frozen encoder turns them into tokens,
stored per episode as float16 (`cache_features`), so training never renders or encodes again.
"""

from __future__ import annotations

import json
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


def random_shift(images: np.ndarray, pad: int, rng: np.random.Generator) -> np.ndarray:
    """(..., H, W, 3) uint8 images, each moved by its own whole-pixel offset in [-pad, pad] along both axes (edge
    pixels repeated into the gap): the random-shift augmentation of image-based RL and imitation (DrQ)."""
    flat = images.reshape(-1, *images.shape[-3:])
    h, w = flat.shape[1:3]
    padded = np.pad(flat, ((0, 0), (pad, pad), (pad, pad), (0, 0)), mode="edge")
    offsets = rng.integers(0, 2 * pad + 1, size=(len(flat), 2))
    out = np.stack([padded[k, dy:dy + h, dx:dx + w] for k, (dy, dx) in enumerate(offsets)])
    return out.reshape(images.shape)


def _rendered_episodes(h5_path, cameras, size, progress, stride, control_mode, renders: Optional[Path]):
    """(images, frames, actions in `control_mode`, seed) per episode: from the render cache `renders` when it
    holds this file's frames, else rendered (and then written to `renders`, if given)."""
    recorded = replay_env_kwargs(load_demo_json(Path(h5_path))).get("control_mode")
    mode = control_mode or recorded or ""
    identity = {"cameras": list(cameras), "size": size, "stride": stride, "control_mode": mode}
    if mode != (recorded or ""):  # converted actions (caches made before the conversion replayed from the seeded
        identity["actions"] = "joint targets from the seeded reset"  # reset hold other actions: refused, not reused)
    if renders is not None and Path(renders).is_file():
        data = np.load(renders)
        held = json.loads(str(data["identity"]))
        if held != identity:
            raise ValueError(f"{renders} holds renders of {held}, not {identity}: delete it to render again")
        return [(data[f"images_{i}"], data[f"frames_{i}"], data[f"actions_{i}"], int(s))
                for i, s in enumerate(data["seeds"])], mode
    converted = None
    if mode != (recorded or ""):
        if mode != TARGET_MODE:
            raise ValueError(f"actions convert to {TARGET_MODE} only, not {control_mode!r}")
        converted = joint_target_episodes(h5_path, progress=progress)
    episodes = []
    for images, frames, actions, ep in demo_frames(h5_path, cameras, size, progress, stride):
        if converted is not None:
            actions, replayed, conv_ep = next(converted)
            if conv_ep["episode_id"] != ep["episode_id"] or not replayed:
                raise RuntimeError(f"{h5_path}: episode {ep['episode_id']} no longer succeeds when replayed for its "
                                   "joint targets; re-record the demos")
        episodes.append((images, frames, np.asarray(actions), int(ep["episode_seed"])))
    if renders is not None:
        arrays = {f"{k}_{i}": v for i, e in enumerate(episodes) for k, v in zip(("images", "frames", "actions"), e)}
        partial = Path(renders).with_suffix(".partial.npz")
        np.savez_compressed(partial, seeds=np.asarray([e[3] for e in episodes]), identity=np.asarray(json.dumps(identity)),
                            **arrays)
        partial.replace(renders)
    return episodes, mode


def cache_features(h5_path, encoder: Encoder, cameras: Sequence[str], out: Path, size: int = 128,
                   progress: bool = False, stride: int = 1, control_mode: Optional[str] = None,
                   renders: Optional[Path] = None, augment_copies: int = 0, augment_shift: int = 0,
                   augment_seed: int = 0) -> Path:
    """Render and encode every episode of a demo file into `out` (.npz: features_<i> float16 of the frames
    frames_<i> (every `stride`-th step), all actions_<i>, seeds, control_mode); an existing file is kept (delete
    it to recompute). `control_mode`: the mode of the stored actions, None for the recorded one, or
    "pd_joint_pos" (absolute joint targets, converted by `demos.joint_targets`). `renders`: a cache of the
    rendered frames (uint8, compressed), read when it exists, else written: another encoder or augmentation
    encodes again without rendering. `augment_copies` > 0: as many randomly shifted copies of every frame
    (`random_shift` by up to `augment_shift` px, seeded) encoded as augmented_<i> (copies, F, tokens, dim)."""
    out = Path(out)
    if out.exists():
        return out
    episodes, mode = _rendered_episodes(h5_path, cameras, size, progress, stride, control_mode, renders)
    rng = np.random.default_rng(augment_seed)
    arrays = {}
    for i, (images, frames, actions, _) in enumerate(episodes):
        arrays[f"features_{i}"] = encode_frames(encoder, images).numpy().astype(np.float16)
        if augment_copies:
            arrays[f"augmented_{i}"] = np.stack([
                encode_frames(encoder, random_shift(images, augment_shift, rng)).numpy().astype(np.float16)
                for _ in range(augment_copies)])
        arrays[f"frames_{i}"] = frames
        arrays[f"actions_{i}"] = actions
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_suffix(".partial.npz")
    np.savez(partial, seeds=np.asarray([e[3] for e in episodes]), encoder=np.asarray(encoder.name),
             cameras=np.asarray(list(cameras)), control_mode=np.asarray(mode), **arrays)
    partial.replace(out)  # complete files only: an interrupted run recomputes
    return out


def load_features(path) -> list[tuple]:
    """The episodes of a feature cache as (features (F, n_obs, dim) float32, actions (T, A), frames (F,)), and
    when the cache holds augmented copies, a fourth entry (copies, F, n_obs, dim): features_[k] is the
    observation before actions[frames[k]]."""
    data = np.load(Path(path))
    n = len(data["seeds"])
    out = []
    for i in range(n):
        feats = torch.from_numpy(data[f"features_{i}"].astype(np.float32))
        frames = data[f"frames_{i}"] if f"frames_{i}" in data else np.arange(len(feats))
        episode = (feats, torch.from_numpy(data[f"actions_{i}"]), torch.from_numpy(np.asarray(frames, np.int64)))
        if f"augmented_{i}" in data:
            episode += (torch.from_numpy(data[f"augmented_{i}"].astype(np.float32)),)
        out.append(episode)
    return out
