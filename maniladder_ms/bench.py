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
    """Rows of {env_id (the label), steps_per_s, ratio, reference_steps_per_s}; targets are env ids or
    `BenchTarget`s. The reference (PickCube-v1 with its own camera, rendering every step) is measured before the
    first target and after each one, and each target's ratio is to the mean of the two reference runs beside it,
    so that a machine whose load drifts over a long list (a shared 2-core machine: PickCube-v1 ran 274 steps/s
    at the start of a 14-task list) compares each target with the reference as loaded when it ran. The reference
    row gives the mean of all its runs. `cameras` / `render_every` apply to the ManiLadder targets: a visual
    policy's view (e.g. the three third-view cameras) and its chunk length."""
    torch.set_num_threads(1)
    targets = [env_target(t) if isinstance(t, str) else t for t in targets]
    references = [steps_per_second(REFERENCE_ENV, steps, obs_mode)]
    rows = []
    for target in targets:
        if progress:
            progress(target.label)
        kwargs = dict(target.make_kwargs)
        if cameras and target.env_id.startswith("ManiLadder-"):
            kwargs["cameras"] = tuple(cameras)
        rate = steps_per_second(target.env_id, steps, obs_mode, render_every=render_every, **kwargs)
        references.append(steps_per_second(REFERENCE_ENV, steps, obs_mode))
        beside = (references[-2] + references[-1]) / 2
        rows.append(dict(env_id=target.label, steps_per_s=rate, ratio=rate / beside, reference_steps_per_s=beside))
    mean = sum(references) / len(references)
    return [dict(env_id=REFERENCE_ENV, steps_per_s=mean, ratio=1.0, reference_steps_per_s=mean)] + rows


def refuse_to_replace(path, update: bool):
    """Raise `FileExistsError` if a bench table exists at `path` and `update` was not asked for."""
    from pathlib import Path

    if Path(path).exists() and not update:
        raise FileExistsError(f"{path} exists: pass --update to replace the rows of the targets measured now "
                              f"(the others are kept)")


def save_rows(path, rows: list[dict], steps: int, obs_mode: str, update: bool = False) -> dict:
    """Record `bench` rows in the JSON table at `path`: {"rows": {label: {ratio, steps_per_s, reference_steps_per_s,
    steps, obs_mode, measured (UTC date), commit}}}. The reference row is not kept
    (every ratio already is to the PickCube-v1 runs beside it). An existing table is only changed with `update`:
    the labels measured now are replaced, the others kept. Returns the table."""
    import datetime
    import json
    from pathlib import Path

    from maniladder_ms.provenance import git_commit

    path = Path(path)
    refuse_to_replace(path, update)
    table = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {"rows": {}}
    measured = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    commit = git_commit()
    for r in rows:
        if r["env_id"] == REFERENCE_ENV:
            continue
        table["rows"][r["env_id"]] = dict(ratio=round(r["ratio"], 3), steps_per_s=round(r["steps_per_s"], 1),
                                          reference_steps_per_s=round(r["reference_steps_per_s"], 1), steps=steps,
                                          obs_mode=obs_mode, measured=measured, commit=commit)
    table["rows"] = dict(sorted(table["rows"].items()))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(table, indent=1) + "\n", encoding="utf-8")
    return table
