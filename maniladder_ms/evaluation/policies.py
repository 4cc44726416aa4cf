"""The policy interface and the built-in policies.

A policy is any callable `policy(obs, spec) -> action`:

- `obs`: the batched observation of one env (batch size 1; torch tensors, nested dicts for visual
  modes). Under the default `--obs-mode rgb` it is `{"sensor_data": {cam: {"rgb": uint8 (1, H, W, 3)}},
  "sensor_param": {...}}` for the four cameras (front, left, top, wrist `hand_camera`), with ManiSkill's
  `agent` (proprioception) and `extra` (task state) parts removed; `rgb+state` keeps them; any other
  ManiSkill obs mode (`state`, `state_dict`, `rgbd`, `pointcloud`, ...) is passed through unchanged.
- `spec`: the task's catalog `TaskSpec` (id, level, suite, skills, horizon, scores...).
- the return value: one action, shape `(A,)` or `(1, A)`, or an action chunk `(T, A)` / `(1, T, A)`
  that is executed open loop (the policy is called again when the chunk is used up or the episode
  ends). numpy arrays, torch tensors and lists are accepted. `A` is the control mode's action size
  (8 for the Panda's default `pd_joint_delta_pos`).

Optional members (duck-typed, all may be absent):

- `image_size`: the side in pixels of the (square) camera images the policy wants (default: the cameras' own,
  128).
- `cameras`: the camera uids the policy looks at (e.g. front, left, top): only those are rendered, and only
  on the steps where the policy is asked for actions (the steps of a chunk before its last render nothing).
- `obs_mode` / `control_mode` attributes: what the policy needs; `obs_mode` overrides `--obs-mode`
  (the built-ins, which ignore observations, use `"none"` to skip rendering); `control_mode` defaults to
  the env's default (`pd_joint_delta_pos`). `env_kwargs(spec) -> dict` may give these per task.
- `reset(ctx)`: called before every episode with an `EpisodeContext` (spec, seed, episode index,
  single-env action space, obs/control mode, horizon, and `instruction`: the episode's language instruction,
  the task's canonical one, or under `--instructions paraphrase` one of it and its paraphrases drawn from the
  episode seed; a language-conditioned policy (VLA) reads it here, and the episode record stores it).
- `supports(spec) -> bool | str`: False or a reason string skips the task (listed as skipped).
- `max_episodes(spec) -> int | None`: fewer episodes for that task (e.g. a demo file with 5 demos).
- `run_episode(env, ctx) -> None`: an *env-driving* policy (oracle). It gets the env itself and
  resets and steps it (e.g. a motion planner); `__call__` is then never used. The runner wraps the env
  so every step is still checked and counted: success and steps are measured from the last
  `env.reset` in the episode; steps beyond the horizon never count.

A class given by `module:Class` is instantiated without arguments; anything else is used as is.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import json
import os
import re
import sys
from pathlib import Path
from typing import Any, Optional

import numpy as np

from maniladder_ms.catalog import TaskSpec, default_catalog


class PolicyError(RuntimeError):
    """A policy that cannot be loaded or that misbehaves (bad action shape, NaN, exception)."""


@dataclasses.dataclass
class EpisodeContext:
    spec: TaskSpec
    seed: int
    episode: int
    action_space: Any  # gymnasium Box of one env (no batch dimension)
    obs_mode: str
    control_mode: str
    horizon: int
    instruction: str = ""  # the episode's language instruction (`TaskSpec.instruction_for`)


BUILTIN_NAMES = ("random", "solver", "replay:<demo.h5 or folder>", "openpi://HOST:PORT")


class RandomPolicy:
    """Uniform random actions in the action space, seeded by the episode seed (reproducible)."""

    name = "random"
    obs_mode = "none"

    def __init__(self):
        self._rng = np.random.default_rng(0)
        self._space = None

    def reset(self, ctx: EpisodeContext):
        self._rng = np.random.default_rng(ctx.seed)
        self._space = ctx.action_space

    def __call__(self, obs, spec: TaskSpec):
        low, high = self._space.low, self._space.high
        return self._rng.uniform(low, high).astype(np.float32)


class SolverPolicy:
    """The task's scripted solver (`maniladder_ms.solvers`): an env-driving oracle in its own control mode."""

    name = "solver"
    obs_mode = "none"

    def supports(self, spec: TaskSpec):
        from maniladder_ms.solvers import find_solver

        return True if find_solver(spec.id) is not None else f"no scripted solver registered for {spec.id}"

    def env_kwargs(self, spec: TaskSpec) -> dict:
        from maniladder_ms.solvers import solver_for

        return {"control_mode": solver_for(spec.id).control_mode}

    def run_episode(self, env, ctx: EpisodeContext):
        from maniladder_ms.solvers import PlanningFailed, solver_for

        try:
            solver_for(ctx.spec.id).run(env, ctx.seed)
        except PlanningFailed as e:  # the oracle failed this episode: a failure, not a bug
            return {"note": f"planning failed: {e}"[:200]}
        return None


class ReplayPolicy:
    """Plays stored ManiSkill demonstrations (h5 + json) open loop: a sanity ceiling.

    `replay:<file.h5>` or `replay:<folder>` (every `*.h5` with its `.json` beside it, matched to tasks
    by the json's `env_info.env_id`). Evaluation episode k plays demo episode k of the task: the env is
    reset with that demo's own seed and reset kwargs (demo seeds, not evaluation seeds: the point is
    to replay the demo), its first stored env state is restored, then its actions are played in its
    control mode. A task has as many episodes as it has demos (`max_episodes`).
    """

    obs_mode = "none"

    def __init__(self, path: str):
        self.path = Path(path)
        if not self.path.exists():
            raise PolicyError(f"replay: {path} does not exist (give a ManiSkill demo .h5 file or a folder of them)")
        files = [self.path] if self.path.is_file() else sorted(
            f for f in self.path.rglob("*.h5")
            if not f.name.endswith(".partial.h5") and not any(p.startswith(".") for p in f.relative_to(self.path).parts)
        )
        if not files:
            raise PolicyError(f"replay: no .h5 demo files under {path}")
        self.name = f"replay:{path}"
        self.demos: dict[str, tuple[Path, list[dict]]] = {}  # env_id -> (h5 path, episodes)
        candidates: dict[str, list] = {}
        for h5 in files:
            meta_path = h5.with_suffix(".json")
            if not meta_path.exists():
                raise PolicyError(f"replay: {h5} has no {meta_path.name} beside it (ManiSkill demos are h5 + json pairs)")
            meta = json.loads(meta_path.read_text())
            try:
                # "maniladder_ms:ManiLadder-X-v1" in demos made for replay_trajectory (gym imports the module first)
                env_id = meta["env_info"]["env_id"].rpartition(":")[2]
                episodes = list(meta["episodes"])
            except (KeyError, TypeError) as e:
                raise PolicyError(f"replay: {meta_path} is not a ManiSkill trajectory json (missing {e})") from None
            candidates.setdefault(env_id, []).append((h5, episodes))
        for env_id, found in candidates.items():
            if len(found) > 1:  # several control modes of one task: the solver's own mode replays exactly
                own = _solver_control_mode(env_id)
                native = [c for c in found if {ep.get("control_mode") for ep in c[1]} == {own}]
                if len(native) != 1:
                    raise PolicyError(f"replay: several demo files for {env_id} ({', '.join(str(c[0]) for c in found)}); "
                                      "give one file with replay:<file.h5>")
                found = native
            self.demos[env_id] = found[0]

    def supports(self, spec: TaskSpec):
        return True if spec.env_id in self.demos else f"no demos for {spec.id} in {self.path}"

    def max_episodes(self, spec: TaskSpec) -> int:
        return len(self.demos[spec.env_id][1])

    def env_kwargs(self, spec: TaskSpec) -> dict:
        episodes = self.demos[spec.env_id][1]
        modes = {ep.get("control_mode") for ep in episodes} - {None}
        if len(modes) > 1:
            raise PolicyError(f"replay: demos of {spec.id} mix control modes {sorted(modes)}")
        return {"obs_mode": "none", "control_mode": modes.pop()} if modes else {"obs_mode": "none"}

    def run_episode(self, env, ctx: EpisodeContext):
        import h5py
        from mani_skill.trajectory.utils import dict_to_list_of_dicts
        from mani_skill.utils import common

        h5_path, episodes = self.demos[ctx.spec.env_id]
        ep = episodes[ctx.episode]
        reset_kwargs = dict(ep.get("reset_kwargs") or {})
        seed = reset_kwargs.get("seed", ep.get("episode_seed"))
        if isinstance(seed, list):
            seed = seed[0]
        reset_kwargs["seed"] = seed
        with h5py.File(h5_path, "r") as f:
            key = f"traj_{ep['episode_id']}"
            if key not in f:
                raise PolicyError(f"replay: {h5_path} has no {key}")
            traj = f[key]
            actions = np.asarray(traj["actions"])
            first_state = None
            if "env_states" in traj:
                first_state = dict_to_list_of_dicts(_h5_to_dict(traj["env_states"]))[0]
        env.reset(**reset_kwargs)
        if first_state is not None:
            env.unwrapped.set_state_dict(common.to_tensor(common.batch(first_state), device=env.unwrapped.device))
        for a in actions:
            _, _, terminated, truncated, _ = env.step(a)
            if bool(np.asarray(terminated).any()) or bool(np.asarray(truncated).any()):
                break
        return {"seed": int(seed) if seed is not None else None}


def _h5_to_dict(group):
    import h5py

    return {k: _h5_to_dict(v) if isinstance(v, h5py.Group) else np.asarray(v) for k, v in group.items()}


class CallablePolicy:
    """Wraps a plain function `fn(obs, spec)` so it has a name."""

    def __init__(self, fn, name: str):
        self.fn = fn
        self.name = name

    def __call__(self, obs, spec):
        return self.fn(obs, spec)


def load_policy(spec: str):
    """A policy object from a `--policy` string: `random`, `solver`, `replay:<path>`, `module:attr`,
    `path/to/file.py:attr`, `openpi://HOST:PORT` (served remotely, `remote`). The object gets a `name` (the string) if it has none."""
    if not isinstance(spec, str) or not spec.strip():
        raise PolicyError("empty --policy; give random, solver, replay:<demos>, module:attr or file.py:attr")
    spec = spec.strip()
    if spec == "random":
        return RandomPolicy()
    if spec == "solver":
        return SolverPolicy()
    if spec.startswith("replay:"):
        return ReplayPolicy(spec[len("replay:"):])
    if spec.startswith("openpi://"):  # a policy served over a websocket (`remote`)
        from .remote import RemotePolicy

        return RemotePolicy(spec)
    if ":" not in spec:
        raise PolicyError(
            f"unknown policy {spec!r}: built-ins are {', '.join(BUILTIN_NAMES)}; "
            "a user policy is given as module:attr or path/to/file.py:attr"
        )
    target, attr = spec.rsplit(":", 1)
    if target.endswith(".py") or os.sep in target:
        path = Path(target)
        if not path.is_file():
            raise PolicyError(f"policy file {target} not found")
        mod_name = "maniladder_user_policy_" + re.sub(r"\W", "_", str(path.resolve()))
        mod_spec = importlib.util.spec_from_file_location(mod_name, path)
        module = importlib.util.module_from_spec(mod_spec)
        sys.modules[mod_name] = module
        try:
            mod_spec.loader.exec_module(module)
        except Exception as e:
            raise PolicyError(f"policy file {target} failed to import: {type(e).__name__}: {e}") from e
    else:
        try:
            module = importlib.import_module(target)
        except ImportError as e:
            raise PolicyError(f"cannot import policy module {target!r}: {e}") from e
    obj: Any = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise PolicyError(f"policy {spec!r}: {target} has no attribute {attr!r}")
        obj = getattr(obj, part)
    if isinstance(obj, type):
        try:
            obj = obj()
        except Exception as e:
            raise PolicyError(f"policy class {spec} could not be instantiated without arguments: {e}") from e
    if not (callable(obj) or hasattr(obj, "run_episode")):
        raise PolicyError(f"policy {spec!r} is a {type(obj).__name__}, not callable and without run_episode")
    if not getattr(obj, "name", None):
        try:
            obj.name = spec
        except AttributeError:
            obj = CallablePolicy(obj, spec)
    return obj


def policy_identity(spec: str) -> str:
    """The policy string a results folder records and a resume must match: `spec`, less the options that change
    no episode (a remote policy's call `timeout`)."""
    if spec.startswith("openpi://"):
        from .remote import spec_identity

        return spec_identity(spec)
    return spec


def policy_label(spec: str) -> str:
    """A file-system friendly short name of a policy string (the default results folder name)."""
    if spec.startswith("replay:"):
        return "replay-" + (Path(spec[7:]).stem or "demos")
    if spec.startswith("openpi://"):
        return re.sub(r"[^A-Za-z0-9_.-]+", "-", "openpi-" + spec[len("openpi://"):].split("?")[0])
    if ":" in spec:
        target, attr = spec.rsplit(":", 1)
        spec = f"{Path(target).stem if target.endswith('.py') else target.split('.')[-1]}-{attr}"
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", spec).strip("-") or "policy"


def _solver_control_mode(env_id: str) -> Optional[str]:
    from maniladder_ms.solvers import find_solver

    spec = next((t for t in default_catalog() if t.env_id == env_id), None)
    solver = find_solver(spec.id) if spec is not None else None
    return solver.control_mode if solver is not None else None


def policy_env_kwargs(policy, spec: TaskSpec, obs_mode: str) -> dict:
    """The obs and control mode an episode of `spec` runs under with `policy` (see the module doc)."""
    kw: dict = {"obs_mode": obs_mode, "control_mode": None, "cameras": None, "image_size": None}
    if getattr(policy, "cameras", None):
        kw["cameras"] = tuple(policy.cameras)
    if getattr(policy, "image_size", None):
        kw["image_size"] = int(policy.image_size)
    if getattr(policy, "obs_mode", None):
        kw["obs_mode"] = policy.obs_mode
    if getattr(policy, "control_mode", None):
        kw["control_mode"] = policy.control_mode
    if hasattr(policy, "env_kwargs"):
        extra = policy.env_kwargs(spec) or {}
        unknown = set(extra) - {"obs_mode", "control_mode", "cameras", "image_size"}
        if unknown:
            raise PolicyError(f"policy env_kwargs may set only obs_mode, control_mode, cameras and image_size, not {sorted(unknown)}")
        kw.update({k: v for k, v in extra.items() if v})
    return kw


def policy_supports(policy, spec: TaskSpec) -> Optional[str]:
    """None if the policy can run `spec`, else the reason it is skipped."""
    if not hasattr(policy, "supports"):
        return None
    ok = policy.supports(spec)
    if ok is True:
        return None
    return ok if isinstance(ok, str) and ok else f"policy does not support {spec.id}"
