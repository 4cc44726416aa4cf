"""Control steps/s of ManiLadder tasks beside ManiSkill's PickCube-v1, measured in one process."""

from __future__ import annotations

import time
from typing import NamedTuple

import gymnasium as gym
import torch

REFERENCE_ENV = "PickCube-v1"


class BenchTarget(NamedTuple):
    """One row of a benchmark: a label and how to make its env."""

    label: str
    env_id: str
    make_kwargs: dict


def env_target(env_id: str, **make_kwargs) -> BenchTarget:
    robot = make_kwargs.get("robot_uids")
    return BenchTarget(f"{env_id} [{robot}]" if robot else env_id, env_id, make_kwargs)


def steps_per_second(env_id: str, steps: int, obs_mode: str = "state", seed: int = 0, **make_kwargs) -> float:
    """Random-action control steps per second (after one warm-up reset), resetting at episode ends."""
    env = gym.make(env_id, obs_mode=obs_mode, render_backend=_backend(), **make_kwargs)
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


def bench(targets: list[BenchTarget | str], steps: int = 300, obs_mode: str = "state", progress=None) -> list[dict]:
    """Rows of {env_id (the label), steps_per_s, ratio}; targets are env ids or `BenchTarget`s; the
    reference is measured before and after, and averaged."""
    torch.set_num_threads(1)
    targets = [env_target(t) if isinstance(t, str) else t for t in targets]
    before = steps_per_second(REFERENCE_ENV, steps, obs_mode)
    rates = {}
    for target in targets:
        if progress:
            progress(target.label)
        rates[target.label] = steps_per_second(target.env_id, steps, obs_mode, **target.make_kwargs)
    after = steps_per_second(REFERENCE_ENV, steps, obs_mode)
    reference = (before + after) / 2
    rows = [dict(env_id=REFERENCE_ENV, steps_per_s=reference, ratio=1.0)]
    rows += [dict(env_id=e, steps_per_s=r, ratio=r / reference) for e, r in rates.items()]
    return rows
