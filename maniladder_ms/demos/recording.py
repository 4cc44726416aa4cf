"""`maniladder demos generate`: run scripted solvers through RecordEpisode, keep the successes.

Seeds are tried in chunks; each chunk is recorded into its own part file under `.parts/` and renamed
into place only when complete, so an interrupted run resumes where it stopped (finished chunks are
not redone) and `--workers K` runs chunks in K processes. When enough successful episodes exist,
the first `num` by seed are merged into the dataset file; each episode entry of its json gets the task's
language `instruction` (the canonical one, or under `instructions="paraphrase"` one drawn from the
episode seed), and the json's `instructions` says which of the two.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import h5py
from tqdm import tqdm

from maniladder_ms.evaluation import EVAL_SEED_BASE as MAX_DEMO_SEED
from maniladder_ms.solvers import solver_for

from .files import ENV_ID_PREFIX, DemoFileError, demo_path, json_path

CHUNK_SIZE = 5


def default_control_modes(task_id: str) -> tuple[str, ...]:
    """The modes `demos generate` records when none is named: the solver's own (first) one. The other modes
    a solver drives are recorded only when asked for (`--control-mode`, repeatable): each is a full run."""
    return (solver_for(task_id).control_mode,)


@dataclass
class GenerateReport:
    task_id: str
    control_mode: str
    path: Path
    attempts: list = field(default_factory=list)  # {seed, success, steps} of every solver run
    kept: int = 0

    @property
    def success_rate(self) -> float:
        return sum(a["success"] for a in self.attempts) / max(len(self.attempts), 1)


def max_attempts_for(num: int, max_attempts: int | None) -> int:
    """Seeds tried before giving up: enough for a solver that succeeds a third of the time."""
    return max_attempts or 3 * num + 20


def _chunk_name(seeds: list[int]) -> str:
    return f"seeds_{seeds[0]:07d}_{seeds[-1]:07d}"


def record_chunk(task_id: str, control_mode: str, obs_mode: str, seeds: list[int], parts_dir: str) -> list[dict]:
    """Run the solver on `seeds` under RecordEpisode; save successful episodes to a part file."""
    import maniladder_ms
    from mani_skill.utils.wrappers.record import RecordEpisode

    from maniladder_ms.solvers import solve_within_horizon

    parts_dir = Path(parts_dir)
    name = _chunk_name(seeds)
    env = maniladder_ms.make(task_id, obs_mode=obs_mode, control_mode=control_mode)
    env = RecordEpisode(
        env, output_dir=str(parts_dir), trajectory_name=f"{name}.partial", save_video=False, save_on_reset=False,
        source_type="scripted", source_desc=f"maniladder_ms scripted solver of {task_id}",
    )
    attempts = []
    try:
        for seed in seeds:
            attempt = solve_within_horizon(env, seed)
            env.flush_trajectory(save=attempt["success"])
            attempts.append(dict(seed=seed, **attempt))
    finally:
        env.close()
    for suffix in (".h5", ".json"):
        (parts_dir / f"{name}.partial{suffix}").replace(parts_dir / f"{name}{suffix}")
    (parts_dir / f"{name}.attempts.json").write_text(json.dumps(attempts))
    return attempts


def record_chunk_files(task_id: str, control_mode: str, obs_mode: str, seeds: list[int]) -> dict[str, bytes]:
    """`record_chunk` in a scratch folder of the worker's own machine; its part files as {name: bytes}, for the
    driver to write (`write_chunk_files`): a worker on another node need not see the driver's folder."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="maniladder-chunk-") as tmp:
        record_chunk(task_id, control_mode, obs_mode, seeds, tmp)
        return {f.name: f.read_bytes() for f in Path(tmp).iterdir() if f.is_file()}


def write_chunk_files(parts_dir: Path, files: dict[str, bytes]) -> list[dict]:
    """Write a chunk's part files into `parts_dir`, its attempts last (their presence marks the chunk finished,
    `_finished_chunks`); returns the attempts."""
    names = sorted(files, key=lambda n: n.endswith(".attempts.json"))
    if not names or not names[-1].endswith(".attempts.json"):
        raise DemoFileError(f"a recorded chunk came back without its attempts file (got {', '.join(names)})")
    for name in names:
        tmp = parts_dir / f"{name}.incoming"
        tmp.write_bytes(files[name])
        tmp.replace(parts_dir / name)
    return json.loads(files[names[-1]])


def _finished_chunks(parts_dir: Path) -> dict[int, list[dict]]:
    """{first seed: attempts} of the chunks a previous run completed."""
    done = {}
    for f in parts_dir.glob("seeds_*.attempts.json"):
        attempts = json.loads(f.read_text())
        done[attempts[0]["seed"]] = attempts
    return done


def generate(
    task_id: str, num: int, out_dir: Path, seed: int = 0, control_mode: str | None = None,
    obs_mode: str = "none", workers: int = 1, overwrite: bool = False, progress: bool = True,
    max_attempts: int | None = None, instructions: str = "canonical", ray_address: str | None = None,
) -> GenerateReport:
    """Record `num` successful solver episodes of `task_id` (seeds from `seed` on) into one h5/json pair, in
    `control_mode` (default the solver's own, first, mode); `instructions` ("canonical" or "paraphrase") picks the
    instruction each episode records. `ray_address` ("local", "auto", "ray://host:10001"): the seed chunks run on
    a Ray cluster's workers (`maniladder_ms.distributed`) instead of `workers` processes."""
    from maniladder_ms.catalog import check_instruction_mode, default_catalog

    spec = default_catalog().get(task_id)
    check_instruction_mode(instructions)
    if ray_address is not None:
        from maniladder_ms.distributed import check_ray_option

        check_ray_option(workers)
    if not (0 <= seed and seed + max_attempts_for(num, max_attempts) <= MAX_DEMO_SEED):
        raise ValueError(f"demo seeds must stay in [0, {MAX_DEMO_SEED}): evaluation seeds start there")
    modes = solver_for(spec.id).control_modes
    control_mode = control_mode or modes[0]
    if control_mode not in modes:
        raise ValueError(f"control mode {control_mode!r}: {spec.id} demos are recorded in one of {', '.join(modes)}")
    out = demo_path(out_dir, spec.id, obs_mode, control_mode)
    parts_dir = out.parent / ".parts" / control_mode
    if out.exists() or json_path(out).exists():
        if not overwrite:
            raise FileExistsError(f"{out} exists; pass --overwrite to replace it")
        out.unlink(missing_ok=True)
        json_path(out).unlink(missing_ok=True)
        shutil.rmtree(parts_dir, ignore_errors=True)
    parts_dir.mkdir(parents=True, exist_ok=True)
    max_attempts = max_attempts_for(num, max_attempts)

    done = _finished_chunks(parts_dir)
    report = GenerateReport(spec.id, control_mode, out)
    successes = lambda: sum(a["success"] for chunk in done.values() for a in chunk)  # noqa: E731
    bar = tqdm(total=num, desc=f"{spec.id} [{control_mode}]", unit="demo", disable=not progress)
    bar.update(min(successes(), num))

    starts = iter(range(seed, seed + max_attempts, CHUNK_SIZE))
    todo = (s for s in starts if s not in done)

    def chunk_seeds(start):
        return list(range(start, min(start + CHUNK_SIZE, seed + max_attempts)))

    def record(start, attempts):
        before = successes()
        done[start] = attempts
        bar.update(min(successes(), num) - min(before, num))

    if ray_address is not None:
        from maniladder_ms.distributed import RayPool, worker_env

        with RayPool(ray_address, worker_env()) as pool:
            while True:
                # as below: count every running seed as a success, so no chunk starts that cannot be needed
                while len(pool) < pool.cpus and successes() + CHUNK_SIZE * len(pool) < num:
                    start = next(todo, None)
                    if start is None:
                        break
                    seeds = chunk_seeds(start)
                    pool.submit(record_chunk_files, (spec.id, control_mode, obs_mode, seeds), key=start,
                                label=f"task {spec.id}, demo seeds {seeds[0]}-{seeds[-1]} [{control_mode}]")
                if not len(pool):
                    break
                unit, files = pool.next_done()
                record(unit.key, write_chunk_files(parts_dir, files))
    elif workers <= 1:
        for start in todo:
            if successes() >= num:
                break
            record(start, record_chunk(spec.id, control_mode, obs_mode, chunk_seeds(start), str(parts_dir)))
    else:
        with mp.get_context("spawn").Pool(workers) as pool:
            pending = {}
            while True:
                # optimistic: count every in-flight seed as a success, so no chunk starts that cannot be needed
                while len(pending) < workers and successes() + CHUNK_SIZE * len(pending) < num:
                    start = next(todo, None)
                    if start is None:
                        break
                    pending[start] = pool.apply_async(
                        record_chunk, (spec.id, control_mode, obs_mode, chunk_seeds(start), str(parts_dir)))
                if not pending:
                    break
                start = next(iter(pending))
                record(start, pending.pop(start).get())
    bar.close()

    report.attempts = [a for start in sorted(done) for a in done[start]]
    report.kept = _merge(parts_dir, out, num, spec, instructions)
    shutil.rmtree(parts_dir.parent)  # the merged file and its json carry everything the parts had
    if report.kept < num:
        raise RuntimeError(
            f"{spec.id}: only {report.kept} successful demos in {len(report.attempts)} attempts "
            f"(solver success {report.success_rate:.0%}); kept them in {out}"
        )
    return report


def _merge(parts_dir: Path, out: Path, num: int, spec, instructions: str) -> int:
    """Copy the first `num` successful episodes (by seed) of all parts into `out`, each with its instruction
    (`spec.instruction_for` under `instructions`); returns the count."""
    episodes = []  # (seed, part h5 path, episode json)
    env_info = source = None
    attempts = []
    for part in sorted(parts_dir.glob("seeds_*.json")):
        if part.name.endswith(".attempts.json"):
            continue
        data = json.loads(part.read_text())
        env_info, source = data["env_info"], {k: data.get(k) for k in ("source_type", "source_desc")}
        episodes += [(ep["episode_seed"], part.with_suffix(".h5"), ep) for ep in data["episodes"]]
        attempts += json.loads(part.with_name(part.stem + ".attempts.json").read_text())
    episodes.sort(key=lambda e: e[0])
    episodes = episodes[:num]
    if env_info is None:
        raise DemoFileError(f"{parts_dir}: no recorded chunks to merge")
    env_info["env_id"] = ENV_ID_PREFIX + env_info["env_id"].removeprefix(ENV_ID_PREFIX)
    tmp = out.with_suffix(".partial.h5")
    merged = []
    with h5py.File(tmp, "w") as dst:
        for new_id, (_, part_h5, ep) in enumerate(episodes):
            with h5py.File(part_h5, "r") as src:
                src.copy(src[f"traj_{ep['episode_id']}"], dst, name=f"traj_{new_id}")
            merged.append(dict(ep, episode_id=new_id, instruction=spec.instruction_for(ep["episode_seed"], instructions)))
    meta = dict(
        env_info=env_info, **source, instructions=instructions, episodes=merged,
        solver=dict(attempts=len(attempts), successes=sum(a["success"] for a in attempts)),
    )
    json_path(tmp).write_text(json.dumps(meta, indent=2))
    tmp.replace(out)
    json_path(tmp).replace(json_path(out))
    return len(merged)
