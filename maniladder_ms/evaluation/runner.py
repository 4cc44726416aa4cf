"""Running a policy under the evaluation protocol (version `PROTOCOL_VERSION`).

Protocol:
- Tasks: implemented catalog tasks only. `--tasks` naming an unimplemented task is an error; with
  `--level`/`--suite`/nothing, unimplemented tasks (and tasks the policy does not support, e.g. no demo
  for `replay`) are listed in the manifest as skipped, and count as not evaluated (coverage).
- Seeds: episode k of every task resets with seed `EVAL_SEED_BASE + seed * EVAL_SEED_STRIDE + k`
  (1,000,000 + 10,000 * --seed + k): fixed, and disjoint from demo seeds, which are kept below 1,000,000.
- Env: `maniladder_ms.make(task)` with the task's catalog horizon as the time limit, default scene (no
  domain randomisation), sparse reward, the policy's control mode (default `pd_joint_delta_pos`) and
  obs mode (default `rgb`: four 128x128 RGB cameras, state parts removed; see `policies`).
- Episodes are order-independent (protocol 2): every seeded reset starts from fresh physics (the base env's
  `fresh_physics_per_seed`), so an episode's outcome depends on the policy, the task and its seed alone, not
  on the episodes before it, the worker that ran it or a resume. Each record carries `state_digest`, a hash of
  the env state at the episode's end, so two runs can be compared episode by episode.
- Cameras: `cameras` (`--cameras front_camera,...`) is the subset of each task's cameras a policy may see (in
  process or remote); only those are rendered and returned. It is part of a run's identity in the manifest (`all`
  by default), so runs under different subsets are never mixed. A name a task lacks is an error listing its cameras.
- Success: the task's success rule holds at some control step <= the horizon. ManiSkill ends an episode
  at its first success (terminated), so this is also the state at the end of the episode. An episode whose
  simulation state goes non-finite (PhysX diverged; `simulation_diverged`) ends there as a failure marked
  `diverged`, and the summary counts them per task.
- Instructions: each episode's `EpisodeContext.instruction` is the task's canonical instruction, or with
  `instructions="paraphrase"` one of it and its paraphrases drawn from the task and the episode seed
  (reproducible); the episode record stores the one used.
- Records: one JSON line per finished episode (task, episode, seed, success, steps, wall_s, policy_s,
  level, suite, obs/control mode, instruction), appended as each finishes; a re-run with the same `--out` runs only
  the episodes not on disk yet.
"""

from __future__ import annotations

import contextlib
import hashlib

import concurrent.futures as cf
import multiprocessing as mp
import time
import traceback
from pathlib import Path
from typing import Optional

import gymnasium as gym
import numpy as np

from maniladder_ms.catalog import check_instruction_mode, default_catalog

from . import EVAL_SEED_BASE, EVAL_SEED_STRIDE, PROTOCOL_VERSION, eval_seed
from .policies import EpisodeContext, PolicyError, load_policy, policy_env_kwargs, policy_identity, policy_supports
from .results import ALL_CAMERAS, EpisodeLog, open_run, read_episodes, read_manifest, write_summary

DEFAULT_OBS_MODE = "rgb"
IMAGELESS_OBS_MODES = ("none", "state", "state_dict")  # obs modes without camera images
STATE_KEYS = ("agent", "extra")  # the parts of ManiSkill's visual observations the default mode removes


def maniskill_obs_mode(obs_mode: str) -> str:
    """The ManiSkill obs mode behind a protocol obs mode (`rgb+state` is ManiSkill's full `rgb`)."""
    return "rgb" if obs_mode == "rgb+state" else obs_mode


def filter_obs(obs, obs_mode: str):
    """What the policy sees: under `rgb`, ManiSkill's rgb observation without its state parts."""
    if obs_mode == "rgb" and isinstance(obs, dict):
        return {k: v for k, v in obs.items() if k not in STATE_KEYS}
    return obs


def _to_numpy(x):
    if hasattr(x, "detach"):  # torch
        x = x.detach().cpu().numpy()
    return np.asarray(x, dtype=np.float32)


def as_action_chunk(raw, action_dim: int, where: str) -> np.ndarray:
    """A policy output as a (T, A) float32 chunk; PolicyError for another shape, NaN or inf."""
    try:
        a = _to_numpy(raw)
    except (TypeError, ValueError) as e:
        raise PolicyError(f"{where}: the policy returned {type(raw).__name__}, not an array of actions ({e})") from None
    shape = a.shape
    if a.ndim == 1 and shape[0] == action_dim:
        a = a[None]
    elif a.ndim == 2 and shape[1] == action_dim and shape[0] >= 1:
        pass
    elif a.ndim == 3 and shape[0] == 1 and shape[2] == action_dim and shape[1] >= 1:
        a = a[0]
    else:
        raise PolicyError(
            f"{where}: the policy returned an action of shape {tuple(shape)}; expected ({action_dim},) or "
            f"(1, {action_dim}) for one action, or (T, {action_dim}) / (1, T, {action_dim}) for a chunk"
        )
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise PolicyError(f"{where}: the policy returned a non-finite action (value {a[tuple(bad)]} at index {tuple(int(i) for i in bad)})")
    return a


def state_digest(base) -> str:
    """A hash of the env state (float32 bytes, memory fields included): equal digests, equal episodes' ends."""
    state = base.get_state()
    return hashlib.sha1(np.ascontiguousarray(_to_numpy(state)).tobytes()).hexdigest()[:16]


def reached_flags(info: dict) -> set[str]:
    """The names of a task's intermediate flags (`evaluate`'s boolean entries besides success and fail: grasped,
    lifted, over the tray, ...) that hold in `info`: recorded per episode, they show how far a failing policy got."""
    out = set()
    for key, value in info.items():
        if key in ("success", "fail") or not (hasattr(value, "dtype") and str(value.dtype) in ("torch.bool", "bool")):
            continue
        if bool(np.asarray(_to_numpy(value)).any()):
            out.add(key)
    return out


def scalar_measures(info: dict) -> dict[str, float]:
    """A task's continuous measures in `info` (`evaluate`'s float entries with one value: a lift's height, a tilt, a
    wheel's turn, a fill count as float): with `reached_flags`, how far a failing policy got."""
    out = {}
    for key, value in info.items():
        if hasattr(value, "dtype") and "float" in str(value.dtype):
            value = np.asarray(_to_numpy(value))
            if value.size == 1:
                out[key] = float(value.reshape(-1)[0])
    return out


class EpisodeMonitor(gym.Wrapper):
    """Checks every action and measures the episode since the last reset: steps, success within the
    horizon. Env-driving policies get the env through it, so the protocol holds for them too."""

    def __init__(self, env, spec, action_dim: int):
        super().__init__(env)
        self.task_spec_ = spec
        self.action_dim = action_dim
        self.horizon = spec.horizon
        self.video = None  # an `EpisodeVideo` while the episode is filmed (`--videos`)
        self.begin()

    def begin(self):
        self.seed = None
        self.resets = 0
        self.steps = 0
        self.success_step: Optional[int] = None
        self.reached: set[str] = set()
        self.measures: dict[str, dict[str, float]] = {}

    def reset(self, *, seed=None, options=None):
        self.resets += 1
        self.seed = seed
        self.steps = 0
        self.success_step = None
        self.reached = set()
        self.measures = {}
        out = self.env.reset(seed=seed, options=options)
        if self.video is not None:
            self.video.add(self.env.unwrapped, out[0], 0, False)
        return out

    def step(self, action):
        where = f"task {self.task_spec_.id}, step {self.steps + 1} (seed {self.seed})"
        chunk = as_action_chunk(action, self.action_dim, where)
        if chunk.shape[0] != 1:
            raise PolicyError(f"{where}: env.step got {chunk.shape[0]} actions at once; step one action at a time")
        obs, reward, terminated, truncated, info = self.env.step(chunk)
        self.steps += 1
        if self.success_step is None and self.steps <= self.horizon and bool(np.asarray(_to_numpy(info["success"])).any()):
            self.success_step = self.steps
        if self.steps <= self.horizon:
            self.reached |= reached_flags(info)
            for key, v in scalar_measures(info).items():
                m = self.measures.setdefault(key, {"min": v, "max": v})
                m.update(min=min(m["min"], v), max=max(m["max"], v), last=v)
            if self.video is not None:
                self.video.add(self.env.unwrapped, obs, self.steps, self.success_step is not None)
        return obs, reward, terminated, truncated, info


def simulation_diverged(base) -> bool:
    """Whether the simulation's state (actor poses and velocities, joint positions and velocities) holds a
    non-finite value: PhysX diverged, as LiftRopeBimanual's rope did under one policy's actions (seed 1010025, step
    57), and a rule evaluated on such a state means nothing. Such an episode ends there and counts as a failure,
    marked `diverged` in its record (no success that a non-finite state might produce is scored). ~4 ms a check
    on this machine, so the runner checks once per action chunk and at the episode's end."""
    import torch

    return not bool(torch.isfinite(base.get_state()).all())


class EpisodeRunner:
    """Runs episodes of one policy, one env per task kept open between episodes of that task."""

    def __init__(self, policy, obs_mode: str = DEFAULT_OBS_MODE, instructions: str = "canonical"):
        self.policy = policy
        self.obs_mode = obs_mode
        self.instructions = instructions
        self._key = None
        self._env: Optional[EpisodeMonitor] = None

    def close(self):
        if self._env is not None:
            self._env.close()
            self._env = None
            self._key = None

    def env_for(self, spec, env_kwargs: dict) -> EpisodeMonitor:
        import maniladder_ms

        key = (spec.id, env_kwargs.get("obs_mode"), env_kwargs.get("control_mode"), env_kwargs.get("cameras"),
               env_kwargs.get("image_size"))
        if key != self._key:
            self.close()
            kw = {"obs_mode": maniskill_obs_mode(env_kwargs["obs_mode"]), "reward_mode": "sparse"}
            if env_kwargs.get("control_mode"):
                kw["control_mode"] = env_kwargs["control_mode"]
            if env_kwargs.get("cameras"):
                kw["cameras"] = env_kwargs["cameras"]
            if env_kwargs.get("image_size"):
                kw["sensor_configs"] = dict(width=env_kwargs["image_size"], height=env_kwargs["image_size"])
            try:
                env = maniladder_ms.make(spec.id, **kw)
            except ValueError as e:
                if not str(e).startswith("unknown camera"):
                    raise
                raise ValueError(f"task {spec.id}: {e} (asked by --cameras or the policy's cameras)") from None
            self._env = EpisodeMonitor(env, spec, int(env.unwrapped.single_action_space.shape[0]))
            self._key = key
        return self._env

    def run(self, spec, episode: int, seed: int, env_kwargs: Optional[dict] = None,
            video_root: Optional[Path] = None) -> dict:
        """One episode; with `video_root` (the results folder) it is filmed (`videos`) and its record names the
        video."""
        env_kwargs = env_kwargs or policy_env_kwargs(self.policy, spec, self.obs_mode)
        env = self.env_for(spec, env_kwargs)
        base = env.unwrapped
        if video_root is None:
            return self._run(env, spec, episode, seed, env_kwargs)
        from .videos import VIDEO_DIR, EpisodeVideo, video_name

        env.video = EpisodeVideo(Path(video_root) / VIDEO_DIR / spec.id, spec.horizon, base.control_freq)
        try:
            rec = self._run(env, spec, episode, seed, env_kwargs)
            rec["video"] = video_name(spec.id, episode, rec["seed"], rec["success"])
            env.video.finish(Path(video_root) / rec["video"])
        except BaseException:
            env.video.discard()
            raise
        finally:
            env.video = None
        return rec

    def _run(self, env, spec, episode: int, seed: int, env_kwargs: dict) -> dict:
        base = env.unwrapped
        ctx = EpisodeContext(spec=spec, seed=seed, episode=episode, action_space=base.single_action_space,
                             obs_mode=env_kwargs["obs_mode"], control_mode=base.control_mode, horizon=spec.horizon,
                             instruction=spec.instruction_for(seed, self.instructions))
        env.begin()
        policy_s = 0.0
        note = None
        t0 = time.perf_counter()
        if hasattr(self.policy, "run_episode"):
            try:
                out = self.policy.run_episode(env, ctx)
            except PolicyError:
                raise
            except Exception as e:
                raise PolicyError(
                    f"task {spec.id}, step {env.steps} (seed {env.seed}): the env-driving policy raised "
                    f"{type(e).__name__}: {e}\n{traceback.format_exc(limit=-3)}"
                ) from e
            if env.resets == 0:
                raise PolicyError(f"task {spec.id}: the env-driving policy never reset the env (call env.reset(seed=ctx.seed))")
            note = (out or {}).get("note") if isinstance(out, dict) else None
            policy_s = time.perf_counter() - t0
        else:
            obs, _ = env.reset(seed=seed)
            if hasattr(self.policy, "reset"):
                self.policy.reset(ctx)
            done = False
            while not done and env.steps < spec.horizon:
                if simulation_diverged(base):  # checked per chunk: a diverged state stays non-finite
                    break
                where = f"task {spec.id}, step {env.steps + 1} (seed {seed})"
                t1 = time.perf_counter()
                try:
                    raw = self.policy(filter_obs(obs, env_kwargs["obs_mode"]), spec)
                except PolicyError:
                    raise
                except Exception as e:
                    raise PolicyError(f"{where}: the policy raised {type(e).__name__}: {e}") from e
                policy_s += time.perf_counter() - t1
                chunk = as_action_chunk(raw, env.action_dim, where)
                for i, action in enumerate(chunk):
                    # only the chunk's last step renders: the policy sees nothing in between
                    with base.sensors_off() if i < len(chunk) - 1 else contextlib.nullcontext():
                        obs, _, terminated, truncated, _ = env.step(action[None])
                    if bool(np.asarray(_to_numpy(terminated)).any()) or bool(np.asarray(_to_numpy(truncated)).any()) \
                            or env.steps >= spec.horizon:
                        done = True
                        break
        wall = time.perf_counter() - t0
        diverged = simulation_diverged(base)
        success = env.success_step is not None and not diverged
        rec = {
            "task": spec.id, "episode": episode, "seed": env.seed if env.seed is not None else seed,
            "success": success, "steps": env.success_step if success else min(env.steps, spec.horizon),
            "wall_s": round(wall, 4), "policy_s": round(policy_s, 4), "level": spec.level, "suite": spec.suite,
            "obs_mode": env_kwargs["obs_mode"], "control_mode": base.control_mode,
            "reached": sorted(env.reached),  # intermediate flags that held at some step (`reached_flags`)
            # each continuous measure's (`scalar_measures`) least, greatest and last value within the horizon
            "measures": {k: {q: float(f"{x:.5g}") for q, x in m.items()} for k, m in sorted(env.measures.items())},
            "state_digest": state_digest(base),
            "instruction": ctx.instruction,
            "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        }
        if note:
            rec["note"] = note
        if diverged:
            rec["diverged"] = True
        return rec


def camera_subset(cameras) -> Optional[tuple[str, ...]]:
    """`--cameras` as sorted unique camera uids, or None (every camera of each task): a list, or a comma-separated
    string; None, "" and "all" mean every camera."""
    if cameras is None or (isinstance(cameras, str) and cameras.strip() in ("", ALL_CAMERAS)):
        return None
    names = cameras.split(",") if isinstance(cameras, str) else list(cameras)
    subset = tuple(sorted({str(c).strip() for c in names if str(c).strip()}))
    if not subset:
        raise ValueError(f"--cameras {cameras!r} names no camera; give camera uids such as front_camera,hand_camera")
    return subset


def restrict_cameras(env_kwargs: dict, cameras: Optional[tuple], spec) -> dict:
    """A task's env kwargs under the camera subset: the policy's own cameras (which must lie in the subset), or
    the subset."""
    if cameras is None:
        return env_kwargs
    if env_kwargs.get("obs_mode") in IMAGELESS_OBS_MODES:
        raise ValueError(f"--cameras restricts the camera images a policy sees, but the policy runs {spec.id} under obs "
                         f"mode {env_kwargs.get('obs_mode')!r}, which has none; leave --cameras out for it")
    own = env_kwargs.get("cameras")
    if own:
        outside = sorted(set(own) - set(cameras))
        if outside:
            raise PolicyError(f"task {spec.id}: the policy looks at {', '.join(outside)}, outside --cameras "
                              f"{','.join(cameras)}")
        return env_kwargs
    return dict(env_kwargs, cameras=cameras)


def select_tasks(catalog, tasks=None, level=None, suite=None):
    """(specs to run, {task id: why skipped}) for a selection; see the module doc."""
    import maniladder_ms

    if tasks:
        if level is not None or suite is not None:
            raise ValueError("give either --tasks or --level/--suite, not both")
        specs = [catalog.get(t) for t in tasks]
        for s in specs:
            if not s.implemented:
                raise maniladder_ms.TaskNotImplementedError(
                    f"task {s.id} ({s.suite}) is in the catalog but not implemented yet, so it cannot be evaluated; "
                    "`maniladder list --implemented` shows the ones that are"
                )
        return list({s.id: s for s in specs}.values()), {}
    specs = catalog.filter(level=level, suite=suite)
    skipped = {s.id: "not implemented" for s in specs if not s.implemented}
    return [s for s in specs if s.implemented], skipped


# ---- process workers ---------------------------------------------------------------------------
_WORKER: dict = {}


def _worker_init(policy_spec: str, obs_mode: str, instructions: str):
    import maniladder_ms  # noqa: F401  (registers the envs)

    _WORKER["runner"] = EpisodeRunner(load_policy(policy_spec), obs_mode, instructions)


def _worker_run(task_id: str, episode: int, seed: int, env_kwargs: dict, video_root: Optional[str] = None) -> dict:
    return _WORKER["runner"].run(default_catalog().get(task_id), episode, seed, env_kwargs,
                                 None if video_root is None else Path(video_root))


def run_episode_in_worker(policy_spec: str, obs_mode: str, instructions: str, task_id: str, episode: int, seed: int,
                          env_kwargs: dict) -> dict:
    """One episode in a long-lived worker process that was not set up for one run (a Ray worker): the runner
    (policy loaded, env kept open) is made on first use and kept while the run stays the same."""
    key = (policy_spec, obs_mode, instructions)
    if _WORKER.get("key") != key:
        if "runner" in _WORKER:
            _WORKER.pop("runner").close()
        _worker_init(policy_spec, obs_mode, instructions)
        _WORKER["key"] = key
    return _worker_run(task_id, episode, seed, env_kwargs)


def evaluate(
    policy,
    out,
    tasks=None,
    level: Optional[int] = None,
    suite: Optional[str] = None,
    episodes: int = 20,
    seed: int = 0,
    obs_mode: str = DEFAULT_OBS_MODE,
    workers: int = 1,
    progress: bool = True,
    bootstrap: int = 2000,
    instructions: str = "canonical",
    cameras=None,
    ray_address: Optional[str] = None,
    videos: int = 0,
) -> dict:
    """Evaluate `policy` (a `--policy` string, or a policy object with workers=1) into folder `out`;
    resumes what is there. `instructions`: "canonical" or "paraphrase" (see the module doc). `cameras`: the
    camera subset the policy may see (`camera_subset`; default every camera), part of the run's identity.
    `ray_address` ("local", "auto", "ray://host:10001"): episodes run on a Ray cluster instead
    (`maniladder_ms.distributed`). `videos`: the first that many episodes of each task are filmed into
    `out/videos/` (`videos`; not part of the run's identity: filming changes no outcome). Returns the summary (also
    written to `out/summary.json`)."""
    import maniladder_ms  # noqa: F401
    from tqdm import tqdm

    from .stats import summarize

    if episodes < 1 or episodes > EVAL_SEED_STRIDE:
        raise ValueError(f"--episodes must be in [1, {EVAL_SEED_STRIDE}], got {episodes}")
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    if ray_address is not None:
        from maniladder_ms.distributed import check_ray_option

        check_ray_option(workers)
    check_instruction_mode(instructions)
    from .videos import check_videos_option

    videos = check_videos_option(videos, ray_address)
    cameras = camera_subset(cameras)
    if isinstance(policy, str):
        policy_spec, policy_obj = policy, load_policy(policy)
    else:
        if workers > 1 or ray_address is not None:
            raise ValueError("workers > 1 and Ray need the policy as a string (module:attr), which each worker "
                             "process loads")
        policy_obj = policy
        policy_spec = getattr(policy, "name", None) or f"{type(policy).__module__}:{type(policy).__qualname__}"
    catalog = default_catalog()
    specs, skipped = select_tasks(catalog, tasks, level, suite)
    runnable, per_task_n, task_env = [], {}, {}
    for spec in specs:
        why = policy_supports(policy_obj, spec)
        if why:
            skipped[spec.id] = why
            continue
        n = episodes
        if hasattr(policy_obj, "max_episodes"):
            cap = policy_obj.max_episodes(spec)
            n = n if cap is None else min(n, int(cap))
        runnable.append(spec)
        per_task_n[spec.id] = n
        task_env[spec.id] = restrict_cameras(policy_env_kwargs(policy_obj, spec, obs_mode), cameras, spec)
    if not runnable:
        reasons = "; ".join(f"{k}: {v}" for k, v in list(skipped.items())[:5])
        raise ValueError(f"nothing to evaluate: no implemented task the policy supports in the selection ({reasons})")

    out = Path(out)
    runner = EpisodeRunner(policy_obj, obs_mode, instructions)
    if cameras is not None and read_manifest(out) is None:  # unknown cameras fail before a new folder is written
        try:
            runner.env_for(runnable[0], task_env[runnable[0].id])
        except BaseException:
            runner.close()
            raise
    manifest = {
        "protocol_version": PROTOCOL_VERSION, "policy": policy_identity(policy_spec), "obs_mode": obs_mode, "seed": seed,
        "instructions": instructions, "cameras": list(cameras) if cameras else ALL_CAMERAS,
        "episodes": episodes, "tasks": [s.id for s in runnable], "skipped": skipped, "task_env": task_env,
        "seed_scheme": f"{EVAL_SEED_BASE} + {EVAL_SEED_STRIDE} * seed + episode",
        "maniladder_version": maniladder_ms.__version__, "catalog_version": catalog.version,
    }
    try:
        manifest = open_run(out, manifest)
    except BaseException:
        runner.close()
        raise
    done = {(r["task"], r["episode"]) for r in read_episodes(out, repair=True)}
    jobs = [(spec, k, eval_seed(seed, k)) for spec in runnable for k in range(per_task_n[spec.id])
            if (spec.id, k) not in done]

    log = EpisodeLog(out)
    bar = tqdm(total=len(jobs), desc=f"eval {policy_spec}", unit="ep", disable=not progress, dynamic_ncols=True)
    counts: dict = {}

    def record(rec):
        log.append(rec)
        s, n = counts.get(rec["task"], (0, 0))
        counts[rec["task"]] = (s + rec["success"], n + 1)
        bar.update(1)
        bar.set_postfix_str(f"{rec['task']} {counts[rec['task']][0]}/{counts[rec['task']][1]}")

    try:
        if ray_address is not None and jobs:
            runner.close()
            from maniladder_ms.distributed import evaluate_episodes

            evaluate_episodes(jobs, policy_spec, obs_mode, instructions, task_env, ray_address, record)
        elif workers == 1 or len(jobs) <= 1:
            for spec, k, s in jobs:
                record(runner.run(spec, k, s, task_env[spec.id], out if k < videos else None))
        else:
            runner.close()
            ctx = mp.get_context("spawn")
            with cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init,
                                        initargs=(policy_spec, obs_mode, instructions)) as pool:
                futures = [pool.submit(_worker_run, spec.id, k, s, task_env[spec.id], str(out) if k < videos else None)
                           for spec, k, s in jobs]
                try:
                    for fut in cf.as_completed(futures):
                        record(fut.result())
                except BaseException:
                    for f in futures:
                        f.cancel()
                    raise
    finally:
        runner.close()
        bar.close()
        log.close()

    summary = summarize(read_episodes(out), catalog, bootstrap=bootstrap, skipped=manifest.get("skipped"))
    summary["manifest"] = manifest
    write_summary(out, summary)
    return summary
