"""Reading and writing demo files, with clear errors for broken ones."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from maniladder_ms.catalog import UnknownTaskError, default_catalog

# gymnasium imports the module before `module:env_id`, so ManiSkill tools that only `gym.make(env_id)`
# from the json (replay_trajectory) find our envs without importing maniladder_ms themselves
ENV_ID_PREFIX = "maniladder_ms:"
DEMO_NAME = "trajectory"


class DemoFileError(ValueError):
    """A demo file that is missing, corrupt, or not a ManiLadder demo."""


def demo_path(out_dir: Path, task_id: str, obs_mode: str, control_mode: str) -> Path:
    return Path(out_dir) / task_id / f"{DEMO_NAME}.{obs_mode}.{control_mode}.physx_cpu.h5"


def json_path(h5_path: Path) -> Path:
    return Path(h5_path).with_suffix(".json")


def read_trajectory_json(h5_path: Path) -> tuple[Path, dict]:
    """(path, contents) of the json beside the existing trajectory `h5_path`, checked to be a ManiSkill trajectory
    json (`env_info`, `episodes`), whatever its task."""
    if Path(h5_path).suffix == ".json":
        raise DemoFileError(f"{h5_path}: name the demo's .h5 file (its .json is read from beside it)")
    if not Path(h5_path).exists():
        raise DemoFileError(f"{h5_path}: no such file")
    path = json_path(h5_path)
    if not path.exists():
        raise DemoFileError(f"{path}: missing (every demo .h5 needs its .json beside it)")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DemoFileError(f"{path}: not valid JSON ({e})") from e
    if not isinstance(data, dict) or not isinstance(data.get("env_info"), dict) or "episodes" not in data:
        raise DemoFileError(f"{path}: no 'env_info' / 'episodes' (not a ManiSkill trajectory json)")
    return path, data


def load_demo_json(h5_path: Path) -> dict:
    """The json beside `h5_path`, checked to describe a ManiLadder task, with its `task_spec`. Every episode
    has an `instruction`: files recorded before instructions were written get the task's canonical one."""
    path, data = read_trajectory_json(h5_path)
    env_id = data["env_info"].get("env_id", "")
    try:
        data["task_spec"] = default_catalog().get(env_id.removeprefix(ENV_ID_PREFIX))
    except UnknownTaskError as e:
        raise DemoFileError(f"{path}: demo of an unknown task: {e}") from e
    for ep in data["episodes"]:
        ep.setdefault("instruction", data["task_spec"].instruction)
    return data


def open_demo_h5(h5_path: Path) -> h5py.File:
    path = Path(h5_path)
    if not path.exists():
        raise DemoFileError(f"{path}: no such file")
    try:
        return h5py.File(path, "r")
    except OSError as e:
        raise DemoFileError(f"{path}: unreadable or truncated HDF5 file ({e})") from e


def replay_env_kwargs(meta: dict) -> dict:
    """The env kwargs a demo file was recorded with (control mode, agent, ...), less what a replay sets itself
    (the task, obs and render modes, sensor configs)."""
    env_kwargs = dict(meta["env_info"].get("env_kwargs", {}))
    for key in ("task_id", "obs_mode", "render_mode", "sensor_configs"):
        env_kwargs.pop(key, None)
    return env_kwargs


def episode_reset_kwargs(ep: dict) -> dict:
    """`env.reset` kwargs that restart a recorded episode: its own reset kwargs, seeded by its episode seed."""
    reset_kwargs = dict(ep.get("reset_kwargs") or {})
    reset_kwargs.setdefault("seed", ep["episode_seed"])
    return reset_kwargs


def state_at(states: dict, t: int) -> dict:
    """The env state of step `t` (batch of one) out of an episode's stacked `env_states`."""
    return {k: state_at(v, t) if isinstance(v, dict) else v[t : t + 1] for k, v in states.items()}


def flat_state(state: dict) -> np.ndarray:
    """A (nested) state dict as one flat array, keys in sorted order: states compare by their largest |difference|."""
    import torch

    return np.concatenate([
        flat_state(state[k]) if isinstance(state[k], dict) else np.asarray(torch.as_tensor(state[k]).cpu()).ravel()
        for k in sorted(state)
    ])


def torch_state(state: dict):
    """A state dict of arrays as torch tensors, as `set_state_dict` takes it."""
    import torch

    return {k: torch_state(v) if isinstance(v, dict) else torch.as_tensor(v) for k, v in state.items()}


def episode_arrays(h5: h5py.File, episode_id: int, where: str) -> tuple:
    """(actions, env_states dict) of one episode, or a DemoFileError naming what is missing."""
    key = f"traj_{episode_id}"
    try:
        group = h5[key]
        actions = group["actions"][()]
        states = _read_group(group["env_states"])
    except (KeyError, OSError) as e:
        raise DemoFileError(f"{where}: episode {key} is missing or damaged ({e})") from e
    return actions, states


def _read_group(group):
    return {k: _read_group(v) if isinstance(v, h5py.Group) else v[()] for k, v in group.items()}
