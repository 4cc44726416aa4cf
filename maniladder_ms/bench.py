"""Control steps/s of ManiLadder tasks beside ManiSkill's PickCube-v1, measured in one process."""

from __future__ import annotations

import time

import gymnasium as gym
import torch

REFERENCE_ENV = "PickCube-v1"


def steps_per_second(env_id: str, steps: int, obs_mode: str = "state", seed: int = 0) -> float:
    """Random-action control steps per second (after one warm-up reset), resetting at episode ends."""
    env = gym.make(env_id, obs_mode=obs_mode, render_backend=_backend())
    try:
        env.action_space.seed(seed)
        env.reset(seed=seed)
        start = time.perf_counter()
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if bool(terminated.any() | truncated.any()):
                env.reset()
        return steps / (time.perf_counter() - start)
    finally:
        env.close()


def _backend() -> str:
    from maniladder_ms.envs import resolve_render_backend

    return resolve_render_backend(None, "state", None)


def bench(env_ids: list[str], steps: int = 300, obs_mode: str = "state", progress=None) -> list[dict]:
    """Rows of {env_id, steps_per_s, ratio}; the reference is measured before and after, and averaged."""
    torch.set_num_threads(1)
    before = steps_per_second(REFERENCE_ENV, steps, obs_mode)
    rates = {}
    for env_id in env_ids:
        if progress:
            progress(env_id)
        rates[env_id] = steps_per_second(env_id, steps, obs_mode)
    after = steps_per_second(REFERENCE_ENV, steps, obs_mode)
    reference = (before + after) / 2
    rows = [dict(env_id=REFERENCE_ENV, steps_per_s=reference, ratio=1.0)]
    rows += [dict(env_id=e, steps_per_s=r, ratio=r / reference) for e, r in rates.items()]
    return rows
