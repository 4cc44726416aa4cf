"""Control steps/s of ManiLadder tasks beside ManiSkill's PickCube-v1, measured in one process."""

from __future__ import annotations

import contextlib
import time
from typing import NamedTuple, Optional, Sequence

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


def steps_per_second(env_id: str, steps: int, obs_mode: str = "state", seed: int = 0, render_every: int = 1,
                     **make_kwargs) -> float:
    """Random-action control steps per second (after one warm-up reset), resetting at episode ends.

    render_every: on a ManiLadder env with a visual obs mode, only every k-th step renders the cameras (as an
    evaluation that executes action chunks of k open loop); ManiSkill's own envs render every step."""
    env = gym.make(env_id, obs_mode=obs_mode, render_backend=_backend(obs_mode), **make_kwargs)
    try:
        env.action_space.seed(seed)
        env.reset(seed=seed)
        quiet = getattr(env.unwrapped, "sensors_off", None)
        start = time.perf_counter()
        for i in range(steps):
            render = quiet is None or render_every <= 1 or (i + 1) % render_every == 0
            with contextlib.nullcontext() if render else quiet():
                _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            if bool(terminated.any() | truncated.any()):
                env.reset()
        return steps / (time.perf_counter() - start)
    finally:
        env.close()


def _backend(obs_mode: str = "state") -> str:
    from maniladder_ms.envs import resolve_render_backend

    return resolve_render_backend(None, obs_mode, None)


def bench(targets: list[BenchTarget | str], steps: int = 300, obs_mode: str = "state", progress=None,
          cameras: Optional[Sequence[str]] = None, render_every: int = 1) -> list[dict]:
    """Rows of {env_id (the label), steps_per_s, ratio}; targets are env ids or `BenchTarget`s; the
    reference (PickCube-v1 with its own camera, rendering every step) is measured before and after, and
    averaged. `cameras` / `render_every` apply to the ManiLadder targets: a visual policy's view (e.g. the
    three third-view cameras) and its chunk length."""
    torch.set_num_threads(1)
    targets = [env_target(t) if isinstance(t, str) else t for t in targets]
    before = steps_per_second(REFERENCE_ENV, steps, obs_mode)
    rates = {}
    for target in targets:
        if progress:
            progress(target.label)
        kwargs = dict(target.make_kwargs)
        if cameras and target.env_id.startswith("ManiLadder-"):
            kwargs["cameras"] = tuple(cameras)
        rates[target.label] = steps_per_second(target.env_id, steps, obs_mode, render_every=render_every, **kwargs)
    after = steps_per_second(REFERENCE_ENV, steps, obs_mode)
    reference = (before + after) / 2
    rows = [dict(env_id=REFERENCE_ENV, steps_per_s=reference, ratio=1.0)]
    rows += [dict(env_id=e, steps_per_s=r, ratio=r / reference) for e, r in rates.items()]
    return rows
