"""`maniladder demos verify`: replay every episode from its actions and from its env states."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .files import (
    episode_arrays, episode_reset_kwargs, flat_state, load_demo_json, open_demo_h5, state_at, torch_state,
)


@dataclass
class EpisodeCheck:
    episode_id: int
    seed: int
    steps: int
    success_from_actions: bool  # replaying the recorded actions from the seeded reset succeeds
    success_from_states: bool  # the recorded final env state satisfies the success rule
    max_drift: float  # largest |state| difference between the action replay and the recorded states


def verify(path: Path, progress: bool = True) -> list[EpisodeCheck]:
    """Check each episode of the demo file at `path`; raises DemoFileError for broken files."""
    from tqdm import tqdm

    import maniladder_ms

    meta = load_demo_json(path)
    spec = meta["task_spec"]
    env_kwargs = dict(meta["env_info"].get("env_kwargs", {}))
    env_kwargs.pop("task_id", None)
    checks = []
    with open_demo_h5(path) as h5:
        env = maniladder_ms.make(spec.id, **env_kwargs)
        try:
            for ep in tqdm(meta["episodes"], desc=f"verify {Path(path).name}", disable=not progress):
                actions, states = episode_arrays(h5, ep["episode_id"], str(path))
                checks.append(_check_episode(env, ep, actions, states))
        finally:
            env.close()
    return checks


def _check_episode(env, ep: dict, actions: np.ndarray, states: dict) -> EpisodeCheck:
    base = env.unwrapped
    env.reset(**episode_reset_kwargs(ep))
    drift = float(np.abs(flat_state(base.get_state_dict()) - flat_state(state_at(states, 0))).max())
    info = {}
    for t, action in enumerate(actions):
        _, _, _, _, info = env.step(action)
        drift = max(drift, float(np.abs(flat_state(base.get_state_dict()) - flat_state(state_at(states, t + 1))).max()))
    base.set_state_dict(torch_state(state_at(states, len(actions))))
    from_states = bool(base.evaluate()["success"][0])
    return EpisodeCheck(
        episode_id=ep["episode_id"], seed=ep["episode_seed"], steps=len(actions),
        success_from_actions=bool(info["success"][0]), success_from_states=from_states, max_drift=drift,
    )
