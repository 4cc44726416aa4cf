"""Units of work on a Ray cluster: the `--ray [ADDRESS]` option of `maniladder eval`, `demos generate` and
`calibrate`. The only module that imports `ray`, and only when a command asks for it (`pip install
'maniladder-ms[ray]'`).

- `connect(address)`: `None` or `"local"` starts a Ray instance on this machine with its CPUs; anything else
  (`auto`, `ray://host:10001`, `host:6379`) connects to a running cluster. A Ray instance already started in
  this process (a test's `ray.init(num_cpus=2)`) is used as it is.
- `RayPool`: submits units (a module-level function and its arguments, with a label naming the task and seed),
  and hands results back to the driver one at a time as they finish, so the driver writes each finished unit
  as it arrives (the results folder, demo part files) and a killed driver resumes from what it wrote.
- Every unit runs through `run_unit` on the worker: it sets the render backend the driver chose
  (`MANILADDER_RENDER_BACKEND`), pins one torch thread, and checks once per worker process that the worker's
  maniladder_ms sources are the driver's (`source_digest`), since a node at another commit would simulate
  other tasks.
- A worker process that dies (crash, out of memory, lost node) is retried by Ray (`MAX_RETRIES` times); an
  exception inside a unit is not retried (episodes are deterministic: it would fail again) and stops the run
  with an error naming the unit's task and seed (`UnitFailed`).
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable, Iterator, Optional

LOCAL = "local"  # `--ray` without an address: start a Ray instance on this machine
INSTALL_HINT = "pip install 'maniladder-ms[ray]'"
RENDER_ENV = "MANILADDER_RENDER_BACKEND"  # read by `envs.base.resolve_render_backend`
MAX_RETRIES = 3  # times Ray re-runs a unit whose worker process died
PACKAGE = Path(__file__).resolve().parent


class DistributedError(RuntimeError):
    """Ray is missing, the cluster cannot be reached, or a worker cannot run this code."""


class UnitFailed(DistributedError):
    """A unit of work failed on a Ray worker; the message names its task and seed, `unit` is the `Unit`."""

    def __init__(self, message: str, unit: Optional["Unit"] = None):
        super().__init__(message)
        self.unit = unit


def import_ray():
    try:
        import ray
    except ImportError as e:
        raise DistributedError(f"--ray needs the `ray` package, which is not installed here ({e}); install the "
                               f"extra: {INSTALL_HINT}") from None
    return ray


def check_ray_option(workers: int = 1) -> None:
    """A command given `--ray`: not with `--workers K`, and ray importable, before anything is written."""
    if workers > 1:
        raise ValueError("give --workers (processes of this machine) or --ray (a cluster's workers), not both")
    import_ray()


def add_ray_argument(parser) -> None:
    """`--ray [ADDRESS]` on a command's parser (`args.ray`: None without the option, `LOCAL` without an address)."""
    parser.add_argument(
        "--ray", nargs="?", const=LOCAL, default=None, metavar="ADDRESS",
        help="run the units of work on a Ray cluster: without ADDRESS a local Ray instance with this machine's CPUs; "
             f"with one (auto, ray://host:10001) a running cluster whose nodes have maniladder-ms installed at the "
             f"same commit ({INSTALL_HINT})")


def connect(address: Optional[str] = LOCAL):
    """The `ray` module, initialised: a local instance for `None`/`LOCAL`, else the cluster at `address`."""
    ray = import_ray()
    if ray.is_initialized():
        return ray
    try:
        if address in (None, LOCAL):
            ray.init(num_cpus=os.cpu_count(), include_dashboard=False, log_to_driver=False,
                     runtime_env=local_runtime_env())
        else:
            ray.init(address=address, log_to_driver=False)
    except (ConnectionError, RuntimeError, ValueError) as e:
        where = "a local Ray instance" if address in (None, LOCAL) else f"the Ray cluster at {address!r}"
        raise DistributedError(f"could not start or reach {where}: {type(e).__name__}: {e}") from None
    return ray


def local_runtime_env() -> dict:
    """The workers of a Ray instance on this machine import this very package, wherever it lies (a checkout too)."""
    path = os.pathsep.join(p for p in (str(PACKAGE.parent), os.environ.get("PYTHONPATH")) if p)
    return {"env_vars": {"PYTHONPATH": path}}


def cluster_cpus(ray) -> int:
    return max(1, int(ray.cluster_resources().get("CPU", 1)))


@lru_cache(maxsize=1)
@lru_cache(maxsize=None)
def source_digest() -> str:
    """A hash of the package's sources and data tables (.py, .yaml, .json): equal digests, the same code. Once per
    process: the code a process runs is the code it imported."""
    from maniladder_ms.provenance import tree_digest

    return tree_digest("", (".py", ".yaml", ".json"))[:16]


def worker_env(render_backend: Optional[str] = None) -> dict:
    """What every unit's worker sets before running: the driver's render backend choice (if any)."""
    backend = render_backend or os.environ.get(RENDER_ENV)
    return {RENDER_ENV: backend} if backend else {}


def run_unit(fn: Callable, args: tuple, env: dict, driver_digest: str):
    """On a Ray worker: the driver's render backend and one torch thread, the code checked, then `fn(*args)`."""
    import platform

    import torch

    mine = source_digest()
    if mine != driver_digest:
        raise DistributedError(
            f"the Ray worker on {platform.node()} runs maniladder_ms from {PACKAGE} whose sources differ from the "
            f"driver's (digest {mine} there, {driver_digest} on the driver): install the same commit on every node")
    for k, v in env.items():
        os.environ[k] = v
    torch.set_num_threads(1)
    import maniladder_ms  # noqa: F401  (registers the envs)

    return fn(*args)


@dataclass
class Unit:
    label: str  # names the unit's task and seed(s) in errors, e.g. "task PickPlacePen, episode 3 (seed 1000003)"
    key: Any  # what the caller uses to file the result


class RayPool:
    """Units on the cluster, results back one at a time in the order they finish."""

    def __init__(self, address: Optional[str] = LOCAL, env: Optional[dict] = None):
        self.ray = connect(address)
        self.env = dict(env or {})
        self.digest = source_digest()
        self._remote = self.ray.remote(run_unit).options(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)
        self._pending: dict = {}  # object ref -> Unit

    @property
    def cpus(self) -> int:
        return cluster_cpus(self.ray)

    def __len__(self) -> int:
        return len(self._pending)

    def submit(self, fn: Callable, args: tuple, label: str, key: Any = None) -> None:
        ref = self._remote.remote(fn, tuple(args), self.env, self.digest)
        self._pending[ref] = Unit(label, key)

    def next_done(self) -> tuple[Unit, Any]:
        """(unit, result) of the next unit to finish; UnitFailed (naming the unit) if it failed."""
        if not self._pending:
            raise ValueError("no unit is running")
        (ref,), _ = self.ray.wait(list(self._pending), num_returns=1)
        unit = self._pending.pop(ref)
        return unit, self._result(unit, ref)

    def as_completed(self) -> Iterator[tuple[Unit, Any]]:
        while self._pending:
            yield self.next_done()

    def _result(self, unit: Unit, ref):
        exc = self.ray.exceptions
        try:
            return self.ray.get(ref)
        except exc.RayTaskError as e:
            cause = getattr(e, "cause", None) or e
            if isinstance(cause, DistributedError):  # the worker cannot run this code at all
                raise DistributedError(str(cause)) from None
            raise UnitFailed(f"{unit.label} failed on a Ray worker: {type(cause).__name__}: {cause}", unit) from None
        except (exc.WorkerCrashedError, exc.NodeDiedError, exc.OutOfMemoryError, exc.TaskUnschedulableError,
                exc.RayError) as e:
            raise UnitFailed(f"{unit.label}: its Ray worker was lost {MAX_RETRIES + 1} times "
                             f"({type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''})", unit) from None

    def cancel(self) -> None:
        """Stop the units still running (a failure, Ctrl-C): nothing more is written for them."""
        for ref in list(self._pending):
            try:
                self.ray.cancel(ref, force=True)
            except Exception as e:  # a unit that just finished cannot be cancelled; nothing to undo
                print(f"note: could not cancel {self._pending[ref].label}: {e}", file=sys.stderr)
        self._pending.clear()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if self._pending:
            self.cancel()
        return False


# ---- the commands' units --------------------------------------------------------------------------------------
def evaluate_episodes(jobs, policy_spec: str, obs_mode: str, instructions: str, task_env: dict, address: Optional[str],
                      record: Callable[[dict], None]) -> None:
    """`maniladder eval --ray`: one unit per episode (`runner.run_episode_in_worker`, the process workers' episode
    function); `record` files each finished episode on the driver."""
    from maniladder_ms.evaluation.runner import run_episode_in_worker

    # a policy file named relative to the driver's folder is named absolutely for the workers (their folder differs)
    target, sep, attr = policy_spec.rpartition(":")
    if sep and target.endswith(".py") and Path(target).is_file():
        policy_spec = f"{Path(target).resolve()}:{attr}"
    with RayPool(address, worker_env()) as pool:
        for spec, k, seed in jobs:
            pool.submit(run_episode_in_worker, (policy_spec, obs_mode, instructions, spec.id, k, seed, task_env[spec.id]),
                        label=f"task {spec.id}, episode {k} (seed {seed})")
        for _, rec in pool.as_completed():
            record(rec)
