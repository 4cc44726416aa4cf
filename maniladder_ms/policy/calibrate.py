"""`maniladder calibrate`: measure each task's level with the reference policy (LadderFlow, protocol v4).

Per task, in a work folder keyed by the task's version (`<work>/<task>/<task hash>/`, `provenance.task_hash`:
catalog row, module sources, assets), so that a changed task recomputes everything and an unchanged one
resumes where a killed run stopped (a stage whose output exists is not run again; a half-written output never
exists):

1. demos     `demos` (20) solver demonstrations, seeds from 0, in the mode the task's solver drives
             (`demo_control_mode_for`); an existing demo file of that task/mode in `--demos` is used as is.
2. features  every `frame_stride`-th demo frame rendered from the policy's cameras (front, left, top;
             128x128 RGB; the renders kept in `renders.npz`, so another encoder or augmentation re-encodes them without
             rendering) and encoded by the frozen encoder, cached as float16 (`features.npz`), with the
             demo's actions as absolute joint targets (`POLICY_CONTROL_MODE`, `demos.joint_targets`).
3. train     per training seed (`seed_<k>/`), one LadderFlow policy on those features; a checkpoint after every
             `train_steps / checkpoints` steps, holding the optimiser and the RNG state: a resumed training ends
             where an uninterrupted one does.
4. select    only with `checkpoints > 1`: every checkpoint on `selection_episodes` development episodes; the best
             wins, ties to the later one. v4 drops it (one checkpoint: the end of the complete schedule).
5. evaluate  the checkpoint on `episodes` episodes per training seed, a number declared before any is run (a
             work folder never grows its count: no optional stopping), on the seed set of the run's purpose:
             `development` (decisions: refining a task, choosing an instrument; 1 training seed) or `final`
             (the numbers that place tasks; `training_seeds` seeds, pooled). Seed set 0 is retired: it chose the
             randomisation pilot's scales. Seed sets never overlap demo seeds (< 1,000,000).

Result per task: the pooled success rate with its 95 % Wilson interval, the per-seed rates (the spread over
training seeds), the measured level (the band holding the pooled rate; above L1's band: 0, "easier than
Level 1"), and a three-way verdict against the catalog level: the interval inside the catalog level's band,
outside it, or straddling one of its edges. Plus provenance: task hash, commit, package versions, renderer,
device, torch threads. Calibration runs one torch thread per process and renders on the CPU (lavapipe) unless
`--renderer` says otherwise; both are recorded.

Results: `<out>/<task>.json` per task, and `<out>/calibration.json` + `calibration.png` over every task in `<out>`
of this protocol; `maniladder report <out>` renders them with older protocols' rows labelled. A result file of
another protocol or task version is never overwritten without `--replace`; the default `--out` is
`runs/calibration/results`, not the committed `docs/calibration`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import time
from pathlib import Path
from typing import Optional, Sequence

from maniladder_ms.catalog import default_catalog

from .flow import PROTOCOL_VERSION, LadderFlowConfig

# evaluation seed sets (`maniladder eval --seed s`: episode k resets with seed 1,000,000 + 10,000 s + k)
SEED_SETS = {"development": 1, "final": 2}
# the committed development results live in this subfolder of the committed calibration folder (docs/calibration)
DEVELOPMENT_FOLDER = "development"
RETIRED_SEED_SETS = {0: "chose the randomisation pilot's layout scales (v3's evaluation set): no longer held out"}
STAGES = ("demos", "features", "train", "select", "evaluate")
VERDICTS = ("inside", "outside", "straddles")
# the policy acts in absolute joint targets (protocol v2). Measured with v1's network on the same 20 demos
# and features, 20 selection episodes each: end-effector deltas (protocol v1) LiftWideBox 2/10 -> absolute
# joint targets 18/20, PickPlacePen ~1/10 both; deltas integrate their errors over an open-loop chunk, while
# targets only have to be read off the scene
POLICY_CONTROL_MODE = "pd_joint_pos"


@dataclasses.dataclass(frozen=True)
class CalibrationProtocol:
    """Everything besides the network that the protocol fixes; part of every result."""

    demos: int = 20
    demo_seed: int = 0
    frame_stride: int = 2  # demo frames rendered for training: the policy sees every 8th step anyway
    # v4: one checkpoint, no selection stage (v3 evaluated 2 checkpoints on 10 episodes each and kept the
    # better; its 4000-step checkpoint matched the 8000-step one in 11 of 16 runs, and 10 episodes could not
    # tell them apart)
    checkpoints: int = 1
    selection_episodes: int = 10
    # per training seed, declared before any episode runs: 50 pin a rate to about +-13 points (20: +-20, too
    # wide to tell 55 % (L2) from 65 % (L1))
    episodes: int = 50
    training_seeds: int = 3  # final numbers pool 3 training seeds; development runs use the first alone
    purpose: str = "final"  # "final" or "development": the seed set and the number of training seeds

    def __post_init__(self):
        if self.purpose not in SEED_SETS:
            raise ValueError(f"purpose must be one of {sorted(SEED_SETS)}, got {self.purpose!r}")
        if self.checkpoints < 1 or self.episodes < 1 or self.training_seeds < 1:
            raise ValueError("checkpoints, episodes and training_seeds must be >= 1")

    @property
    def seed_set(self) -> int:
        return SEED_SETS[self.purpose]

    @property
    def seeds(self) -> list[int]:
        """The training seeds this run trains and pools."""
        return list(range(1 if self.purpose == "development" else self.training_seeds))

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def demo_control_mode_for(task_id: str) -> str:
    """The mode the calibration demos are recorded in: the policy's own where the solver drives it, else the
    solver's first (the one it is tuned in), converted to joint targets for training."""
    from maniladder_ms.solvers import solver_for

    modes = solver_for(task_id).control_modes
    return POLICY_CONTROL_MODE if POLICY_CONTROL_MODE in modes else modes[0]


def level_ranges(catalog=None) -> dict[int, tuple[float, float]]:
    catalog = catalog or default_catalog()
    return {lv: (float(lo), float(hi)) for lv, (lo, hi) in catalog.level_success_ranges.items()}


def measured_level(rate: float, ranges: Optional[dict] = None) -> int:
    """The level whose calibration interval holds `rate`: L1 [0.60, 0.85], L2 [0.20, 0.60), L3 (0, 0.20),
    L4 0; 0 above L1's interval (easier than Level 1)."""
    ranges = ranges or level_ranges()
    if rate > max(hi for _, hi in ranges.values()):
        return 0
    for level in sorted(ranges):  # the first interval with a positive lower edge that the rate reaches
        lo, hi = ranges[level]
        if lo > 0 and rate >= lo:
            return level
    if rate > 0:  # below every positive edge: the open interval (0, x)
        return min(lv for lv, (lo, hi) in ranges.items() if lo <= 0 < hi)
    return max(lv for lv, (lo, hi) in ranges.items() if hi <= 0)


def verdict(successes: int, episodes: int, level: int, ranges: Optional[dict] = None) -> str:
    """Where the 95 % Wilson interval of `successes / episodes` lies against `level`'s band: "inside" it,
    "outside" it, or "straddles" one of its edges. L4's band is the point 0: inside iff nothing succeeded (the
    interval then reaches up from 0 and says how small the rate is), outside after any success (the rate is then
    surely above 0); L3's (0, 20 %) needs a success to be inside."""
    from maniladder_ms.evaluation.stats import wilson_interval

    ranges = ranges or level_ranges()
    band_lo, band_hi = ranges[level]
    lo, hi = wilson_interval(successes, episodes)
    if band_hi <= 0:  # the point 0
        return "inside" if successes == 0 else "outside"
    if band_lo <= 0:  # open at 0
        if successes == 0:
            return "straddles" if hi > 0 else "outside"
        return "inside" if hi < band_hi else ("straddles" if lo < band_hi else "outside")
    if lo >= band_lo and hi <= band_hi:
        return "inside"
    return "outside" if hi < band_lo or lo > band_hi else "straddles"


def level_text(level: int) -> str:
    return "easier than L1 (above its band)" if level == 0 else f"L{level}"


class TaskCalibration:
    """The stages of one task in `work/<task>/<task hash>/`; `run()` does those not done yet and returns the
    result."""

    def __init__(self, task_id: str, work: Path, out: Path, demos_dir: Optional[Path] = None,
                 config: LadderFlowConfig = LadderFlowConfig(), protocol: CalibrationProtocol = CalibrationProtocol(),
                 device: str = "cpu", renderer: str = "cpu", replace: bool = False, progress: bool = True, log=print,
                 videos: int = 0):
        from maniladder_ms.provenance import task_hash

        self.spec = default_catalog().get(task_id)
        if not self.spec.implemented:
            import maniladder_ms

            raise maniladder_ms.TaskNotImplementedError(f"task {task_id} is not implemented yet; it cannot be calibrated")
        self.config, self.protocol, self.device, self.progress, self.log = config, protocol, device, progress, log
        self.renderer, self.replace = renderer, replace
        self.videos = videos  # the evaluation's first episodes filmed (`maniladder eval --videos`); changes no outcome
        self.task_hash = task_hash(task_id)
        self.dir = Path(work) / task_id / self.task_hash
        self.out = Path(out)
        self.demos_dir = Path(demos_dir) if demos_dir else self.dir / "demos"
        self.control_mode = POLICY_CONTROL_MODE
        self.demo_control_mode = demo_control_mode_for(task_id)
        self.timings_path = self.dir / "timings.json"
        self.cpu_timings_path = self.dir / "cpu_timings.json"  # CPU seconds of this process (its renderer threads
        # included): the cost on one core, unlike the wall time, whatever else the machine runs

    # ---- bookkeeping -------------------------------------------------------------------------------
    def _timings(self, path: Optional[Path] = None) -> dict:
        path = path or self.timings_path
        return json.loads(path.read_text()) if path.is_file() else {}

    def _timed(self, stage: str, fn):
        import fcntl
        import os

        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        spent = {self.timings_path: time.perf_counter() - t0, self.cpu_timings_path: time.process_time() - c0}
        # training seeds of a task may run in parallel (`--ray`): one read-add-write at a time, written whole
        with open(self.dir / ".timings.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            for path, seconds in spent.items():
                timings = self._timings(path)
                timings[stage] = round(timings.get(stage, 0.0) + seconds, 1)
                tmp = path.with_suffix(f".{os.getpid()}.tmp")
                tmp.write_text(json.dumps(timings, indent=1))
                tmp.replace(path)
        return out

    def settings(self) -> dict:
        from maniladder_ms.provenance import package_versions

        versions = package_versions()
        return {"protocol": PROTOCOL_VERSION, "task_hash": self.task_hash, "config": self.config.as_dict(),
                "calibration": self.protocol.as_dict(), "control_mode": self.control_mode,
                "demo_control_mode": self.demo_control_mode, "renderer": self.renderer, "device": self.device,
                "packages": {k: versions[k] for k in ("mani-skill", "sapien", "torch")}}

    def _check_settings(self):
        """A work folder belongs to one configuration, declared episode count included: resuming with another
        one would mix them (or grow the evaluation after its results were seen). The purpose is not part of it: it
        picks only the evaluation's seed set and folder (`seed_<k>/<purpose>/`), so a task version's final run
        evaluates the demos, features and training seed 0 its development runs trained, and trains seeds 1-2."""
        settings = self.settings()
        path = self.dir / "settings.json"
        if path.is_file():
            old = json.loads(path.read_text())

            def shared(s: dict) -> dict:
                return dict(s, calibration={k: v for k, v in s.get("calibration", {}).items() if k != "purpose"})

            if shared(old) != shared(settings):
                diff = sorted(k for k in set(old) | set(settings) if shared(old).get(k) != shared(settings).get(k))
                raise ValueError(f"{self.dir} holds a calibration with other settings ({', '.join(diff)} differ; "
                                 f"{path}); give another --work folder or delete that one")
        else:
            self.dir.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(settings, indent=1))

    @property
    def demo_h5(self) -> Path:
        from maniladder_ms.demos.files import demo_path

        return demo_path(self.demos_dir, self.spec.id, "none", self.demo_control_mode)

    @property
    def features_path(self) -> Path:
        return self.dir / "features.npz"

    @property
    def renders_path(self) -> Path:
        """The demo frames as rendered (`features.cache_features`): another encoder re-encodes them."""
        return self.dir / "renders.npz"

    @property
    def checkpoint_steps(self) -> list[int]:
        n = self.protocol.checkpoints
        return [self.config.train_steps * k // n for k in range(1, n + 1)]

    def seed_dir(self, seed: int) -> Path:
        return self.dir / f"seed_{seed}"

    def checkpoint(self, step: int, seed: int = 0) -> Path:
        return self.seed_dir(seed) / f"checkpoint_{step}.pt"

    # ---- stages ------------------------------------------------------------------------------------
    def stage_demos(self):
        from maniladder_ms.demos.files import load_demo_json
        from maniladder_ms.demos.recording import generate

        if self.demo_h5.is_file():
            n = len(load_demo_json(self.demo_h5)["episodes"])
            if n < self.protocol.demos:
                raise ValueError(f"{self.demo_h5} holds {n} demos; calibration trains on {self.protocol.demos}")
            return
        report = generate(self.spec.id, self.protocol.demos, self.demos_dir, seed=self.protocol.demo_seed,
                          control_mode=self.demo_control_mode, progress=self.progress)
        self.log(f"{self.spec.id}: {report.kept} demos ({report.success_rate:.0%} solver success) -> {report.path}")

    def stage_features(self):
        if self.features_path.is_file():  # before any import: a stage already done adds no time to timings.json
            return
        from .encoders import make_encoder
        from .features import cache_features

        c = self.config
        encoder = make_encoder(c.encoder, grid=c.grid, device=self.device)
        cache_features(self.demo_h5, encoder, c.cameras, self.features_path, size=c.image_size,
                       progress=self.progress, stride=self.protocol.frame_stride, control_mode=self.control_mode,
                       renders=self.renders_path, augment_copies=c.augment_copies, augment_shift=c.augment_shift)

    def stage_train(self, seed: int):
        todo = [step for step in self.checkpoint_steps if not self.checkpoint(step, seed).is_file()]
        if not todo:
            return
        from .features import load_features
        from .flow import LadderFlowTrainer

        episodes = load_features(self.features_path)[: self.protocol.demos]
        trainer = LadderFlowTrainer(dataclasses.replace(self.config, seed=seed), episodes, device=self.device)
        resume = self.seed_dir(seed) / "resume.pt"  # the latest of every RESUME_EVERY steps: a kill loses fewer
        done = [step for step in self.checkpoint_steps if step not in todo]
        start = max(done, default=0)
        if resume.is_file() and torch_step(resume) > start:
            trainer.resume(resume)
        elif done:
            trainer.resume(self.checkpoint(start, seed))
        meta = {"task": self.spec.id, "control_mode": self.control_mode, "task_hash": self.task_hash}
        for step in todo:
            losses = []
            while trainer.step_count < step:
                losses += trainer.train(min(RESUME_EVERY, step - trainer.step_count), progress=self.progress)
                if trainer.step_count < step:
                    trainer.save(resume, meta=meta)
            trainer.save(self.checkpoint(step, seed),
                         meta=dict(meta, final_loss=float(sum(losses[-100:]) / max(len(losses[-100:]), 1))))
        resume.unlink(missing_ok=True)

    def _evaluate(self, step: int, seed: int, folder: str, episodes: int, seed_set: int, videos: int = 0) -> dict:
        from maniladder_ms.evaluation.runner import evaluate

        from .evaluate import LadderFlowEvalPolicy

        policy = LadderFlowEvalPolicy(self.checkpoint(step, seed))
        summary = evaluate(policy, self.seed_dir(seed) / folder, tasks=[self.spec.id], episodes=episodes,
                           seed=seed_set, progress=self.progress, bootstrap=0, videos=videos)
        return summary["tasks"][self.spec.id]

    def stage_select(self, seed: int) -> dict:
        """The checkpoint that acts: the last one, or with several the best on development episodes."""
        steps = self.checkpoint_steps
        if len(steps) == 1:
            return {"selected_step": steps[0]}
        path = self.seed_dir(seed) / "selection.json"
        if path.is_file():
            return json.loads(path.read_text())
        rates = {step: self._evaluate(step, seed, f"select_{step}", self.protocol.selection_episodes,
                                      SEED_SETS["development"])["rate"] for step in steps}
        best = max(rates, key=lambda step: (rates[step], step))
        sel = {"selection_rates": {str(s): r for s, r in rates.items()}, "selected_step": best}
        path.write_text(json.dumps(sel, indent=1))
        return sel

    def stage_evaluate(self, seed: int, sel: dict) -> dict:
        return self._evaluate(sel["selected_step"], seed, self.protocol.purpose, self.protocol.episodes,
                              self.protocol.seed_set, videos=self.videos)

    # ---- all of it ---------------------------------------------------------------------------------
    def run(self) -> dict:
        self.prepare()
        return self.write_result({seed: self.run_seed(seed) for seed in self.protocol.seeds})

    def prepare(self) -> None:
        """The stages every training seed shares: settings checked, demos, features."""
        self._check_settings()
        self._timed("demos", self.stage_demos)
        self._timed("features", self.stage_features)

    def run_seed(self, seed: int) -> tuple[dict, dict]:
        """One training seed after `prepare`: (its evaluation's task summary, the selection)."""
        self._timed("train", lambda: self.stage_train(seed))
        sel = self._timed("select", lambda: self.stage_select(seed))
        return self._timed("evaluate", lambda: self.stage_evaluate(seed, sel)), sel

    def write_result(self, per_seed: dict) -> dict:
        import statistics

        from maniladder_ms.demos.files import load_demo_json
        from maniladder_ms.evaluation.stats import wilson_interval
        from maniladder_ms.provenance import environment

        from .revalidate import demos_digest

        ranges = level_ranges()
        successes = sum(t["successes"] for t, _ in per_seed.values())
        episodes = sum(t["episodes"] for t, _ in per_seed.values())
        rate = successes / episodes
        level = measured_level(rate, ranges)
        rates = [t["rate"] for t, _ in per_seed.values()]
        demos = load_demo_json(self.demo_h5)["episodes"][: self.protocol.demos]
        result = {
            "task": self.spec.id, "suite": self.spec.suite, "catalog_level": self.spec.level,
            "purpose": self.protocol.purpose, "seed_set": self.protocol.seed_set,
            "successes": successes, "episodes": episodes, "success": rate, "ci95": list(wilson_interval(successes, episodes)),
            "measured_level": level, "measured_level_text": level_text(level), "agree": level == self.spec.level,
            "verdict": verdict(successes, episodes, self.spec.level, ranges),
            "per_training_seed": {str(seed): {"successes": t["successes"], "episodes": t["episodes"], "success": t["rate"],
                                              "selection": sel} for seed, (t, sel) in per_seed.items()},
            # how far each training seed's episodes got: the share reaching each of the task's intermediate flags
            "reached": {str(seed): t.get("reached", {}) for seed, (t, _) in per_seed.items()},
            "training_seed_spread": {"min": min(rates), "max": max(rates),
                                     "sd": statistics.stdev(rates) if len(rates) > 1 else None},
            "control_mode": self.control_mode, "demo_control_mode": self.demo_control_mode, "horizon": self.spec.horizon,
            "demo_mean_steps": sum(e["elapsed_steps"] for e in demos) / max(len(demos), 1),
            "mean_steps": statistics.mean(t["mean_steps"] for t, _ in per_seed.values()), "timings_s": self._timings(),
            "cpu_s": self._timings(self.cpu_timings_path),
            "protocol": PROTOCOL_VERSION, "config": self.config.as_dict(), "calibration": self.protocol.as_dict(),
            "task_hash": self.task_hash, "demos_digest": demos_digest(self.demo_h5),
            "environment": environment(renderer=self.renderer, device=self.device),
            "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        }
        path = self.out / f"{self.spec.id}.json"
        if path.is_file():
            old = json.loads(path.read_text())
            # demos_digest and reached follow from what is compared (the task version, demo seeds and episodes) and
            # older results lack them
            volatile = ("time", "timings_s", "cpu_s", "environment", "demos_digest", "reached")
            if {k: v for k, v in old.items() if k not in volatile} == \
                    json.loads(json.dumps({k: v for k, v in result.items() if k not in volatile})):
                return old  # a resume of a finished task: the result stays as it is (no new time stamp to commit)
            if not self.replace:
                raise ResultExistsError(
                    f"{path} holds another result ({_result_label(old)}; this run: {_result_label(result)}); "
                    "nothing was overwritten. Give another --out, or --replace to overwrite it")
        self.out.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(result, indent=1))
        return result


# training saves a resume point this often (steps; ~1-2 min of training on one core, ~4 MB): a killed run loses
# at most that much, and resumes exactly (the checkpoint holds the RNG state)
RESUME_EVERY = 500


def torch_step(path: Path) -> int:
    import torch

    return int(torch.load(path, map_location="cpu", weights_only=False)["step"])


class ResultExistsError(ValueError):
    """A calibration would overwrite a different result file without `replace`."""


def _result_label(r: dict) -> str:
    return (f"protocol {r.get('protocol')}, task version {r.get('task_hash', 'not recorded')}, "
            f"{r.get('successes')}/{r.get('episodes')} on {r.get('purpose', 'final')} seeds")


def _calibrate_one(task_id: str, kwargs: dict) -> dict:
    return TaskCalibration(task_id, **kwargs).run()


# ---- `--ray`: a task's demos and features, then each training seed, as units on a cluster's workers ---------------
CLUSTER_PROBE = ".cluster-probe-{token}"  # written into the work folder by the driver for a run; every unit must see it


def _check_work_visible(kwargs: dict, token: str) -> None:
    import platform

    from maniladder_ms.distributed import DistributedError

    probe = Path(kwargs["work"]) / CLUSTER_PROBE.format(token=token)
    demos = kwargs.get("demos_dir")
    if not probe.is_file() or (demos and not Path(demos).is_dir()):
        raise DistributedError(
            f"the Ray worker on {platform.node()} does not see the driver's work folder {kwargs['work']}"
            + (f" or demos folder {demos}" if demos else "") + ": `calibrate --ray` on several machines needs them on "
            "a file system every node mounts at the same path")


def _prepare_unit(task_id: str, kwargs: dict, token: str) -> None:
    _check_work_visible(kwargs, token)
    TaskCalibration(task_id, progress=False, **kwargs).prepare()


def _seed_unit(task_id: str, seed: int, kwargs: dict, token: str) -> tuple[dict, dict]:
    _check_work_visible(kwargs, token)
    return TaskCalibration(task_id, progress=False, **kwargs).run_seed(seed)


@contextlib.contextmanager
def _removed_after(path: Path):
    try:
        yield path
    finally:
        path.unlink(missing_ok=True)


def _calibrate_on_ray(tasks: Sequence[str], kwargs: dict, address: str, progress: bool, log, on_result=None) -> dict:
    """Every task's `prepare` as a unit, then, as each finishes, one unit per training seed; the driver writes a
    task's result when its last seed is in. Returns {task: why} of the tasks that failed (the others go on)."""
    import secrets

    from tqdm import tqdm

    from maniladder_ms.distributed import RayPool, UnitFailed, worker_env

    work = Path(kwargs["work"])
    work.mkdir(parents=True, exist_ok=True)
    token = secrets.token_hex(8)
    probe = work / CLUSTER_PROBE.format(token=token)
    probe.write_text("the driver of a `calibrate --ray` run wrote this; its workers check that they see it\n")
    seeds = kwargs["protocol"].seeds
    per_seed: dict = {t: {} for t in tasks}
    failed: dict = {}
    bar = tqdm(total=len(tasks) * (1 + len(seeds)), desc="calibrate", unit="unit", disable=not progress)
    with RayPool(address, worker_env(kwargs["renderer"])) as pool, _removed_after(probe):
        for t in tasks:
            pool.submit(_prepare_unit, (t, kwargs, token), key=(t, None), label=f"task {t}: demos and features")
        while len(pool):
            try:
                unit, out = pool.next_done()
            except UnitFailed as e:  # one task's failure leaves the others running
                t = e.unit.key[0]
                failed.setdefault(t, str(e))
                log(f"{t}: FAILED {e}")
                bar.update(1 + (len(seeds) if e.unit.key[1] is None else 0))  # a failed prepare: no seeds follow
                continue
            bar.update(1)
            t, seed = unit.key
            if t in failed:
                continue
            if seed is None:
                for k in seeds:
                    pool.submit(_seed_unit, (t, k, kwargs, token), key=(t, k),
                                label=f"task {t}, training seed {k}")
                continue
            per_seed[t][seed] = out
            if len(per_seed[t]) == len(seeds):
                try:
                    r = TaskCalibration(t, **kwargs).write_result(dict(sorted(per_seed[t].items())))
                    log(_result_line(r))
                    if on_result:
                        on_result(r)
                except ValueError as e:
                    failed[t] = f"{type(e).__name__}: {e}"
                    log(f"{t}: FAILED {failed[t]}")
    bar.close()
    return failed


def calibrate(tasks: Sequence[str], work: Path, out: Path, demos_dir: Optional[Path] = None, device: str = "cpu",
              workers: int = 1, progress: bool = True, config: LadderFlowConfig = LadderFlowConfig(),
              protocol: CalibrationProtocol = CalibrationProtocol(), renderer: str = "cpu", replace: bool = False,
              log=print, ray_address: Optional[str] = None, on_result=None, videos: int = 0) -> dict:
    """Calibrate `tasks` (resuming what `work` holds), then rewrite the summary of every result in `out`.
    `on_result(result)` is called in this process as each task's result is written (a calibration record is
    appended then, not after the last task: a run over many tasks takes days and may be killed on the way).
    Each process runs one torch thread and renders with `renderer` (the env var the envs read, inherited by
    worker processes). `ray_address` ("local", "auto", "ray://host:10001"): tasks and training seeds run on a Ray
    cluster's workers instead (`_calibrate_on_ray`), which must see `work` (and `demos_dir`) at the same path.
    `videos`: the first that many evaluation episodes of each training seed are filmed (`maniladder eval --videos`)
    into its evaluation folder's `videos/`, where an evaluation runs now (a finished one is not re-run)."""
    import concurrent.futures as cf
    import multiprocessing as mp
    import os

    import torch

    kwargs = dict(work=Path(work), out=Path(out), demos_dir=demos_dir, config=config, protocol=protocol, device=device,
                  renderer=renderer, replace=replace, videos=videos)
    for t in tasks:  # bad names and unbuilt tasks fail before any work starts
        TaskCalibration(t, **kwargs)
    if ray_address is not None:
        from maniladder_ms.distributed import check_ray_option

        check_ray_option(workers)
    failed = {}
    previous = os.environ.get(RENDER_ENV), torch.get_num_threads()
    os.environ[RENDER_ENV] = renderer
    torch.set_num_threads(1)  # one task per process and core; worker processes inherit the env var, not this
    try:
        if ray_address is not None:
            failed = _calibrate_on_ray(tasks, kwargs, ray_address, progress, log, on_result)
        elif workers <= 1:
            for t in tasks:
                t0 = time.perf_counter()
                r = TaskCalibration(t, progress=progress, log=log, **kwargs).run()
                log(_result_line(r, time.perf_counter() - t0))
                if on_result:
                    on_result(r)
        else:
            with cf.ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"), initializer=_one_thread) as pool:
                futures = {pool.submit(_calibrate_one, t, dict(kwargs, progress=False)): t for t in tasks}
                for fut in cf.as_completed(futures):
                    try:
                        r = fut.result()
                        log(_result_line(r))
                    except Exception as e:  # one task's failure leaves the others running
                        failed[futures[fut]] = f"{type(e).__name__}: {e}"
                        log(f"{futures[fut]}: FAILED {failed[futures[fut]]}")
                        continue
                    if on_result:
                        on_result(r)
    finally:
        if previous[0] is None:
            os.environ.pop(RENDER_ENV, None)
        else:
            os.environ[RENDER_ENV] = previous[0]
        torch.set_num_threads(previous[1])
    summary = write_summary(out)
    if failed:
        raise RuntimeError("calibration failed for " + "; ".join(f"{t} ({why})" for t, why in failed.items()))
    return summary


RENDER_ENV = "MANILADDER_RENDER_BACKEND"  # read by `envs.base.resolve_render_backend`


def _one_thread():
    import torch

    torch.set_num_threads(1)


def _result_line(r: dict, wall: Optional[float] = None) -> str:
    lo, hi = r["ci95"]
    extra = f" ({wall / 60:.1f} min)" if wall else ""
    return (f"{r['task']}: {r['successes']}/{r['episodes']} = {100 * r['success']:.0f}% [{100 * lo:.0f}, {100 * hi:.0f}] "
            f"-> {r['measured_level_text']}; interval {r['verdict']} catalog L{r['catalog_level']}'s band{extra}")


def load_results(out: Path, protocol: Optional[str] = PROTOCOL_VERSION) -> list[dict]:
    """The task results in `out` measured under `protocol` (None: every protocol; numbers of different
    protocols are not comparable, so only a report that labels them shows them together)."""
    rows = []
    for p in sorted(Path(out).glob("*.json")):
        if p.name == "calibration.json":
            continue
        r = json.loads(p.read_text())
        if "measured_level" in r and (protocol is None or r.get("protocol") == protocol):
            rows.append(r)
    return rows


def stale_reason(r: dict) -> Optional[str]:
    """Why a result no longer measures its task as built (None if it still does, or nobody can tell)."""
    from maniladder_ms.provenance import task_hash

    if r.get("stale"):
        return r["stale"]
    from .revalidate import equivalent_hashes

    if r.get("task_hash") and default_catalog().get(r["task"]).implemented and \
            task_hash(r["task"]) not in equivalent_hashes(r):
        return f"the task changed since (version {r['task_hash']} measured, {task_hash(r['task'])} now)"
    return None


def write_summary(out: Path) -> dict:
    """`calibration.json` (the table) and `calibration.png` (the plot) over every task result in `out` of this
    protocol."""
    out = Path(out)
    rows = load_results(out)
    cols = ("task", "suite", "catalog_level", "purpose", "successes", "episodes", "success", "ci95", "measured_level",
            "measured_level_text", "agree", "verdict", "training_seed_spread", "demo_mean_steps", "timings_s", "cpu_s", "task_hash")
    table = [{c: r.get(c) for c in cols} for r in rows]
    summary = {"protocol": PROTOCOL_VERSION, "tasks": table, "n_tasks": len(rows),
               "n_agree": sum(r["agree"] for r in rows), "n_inside": sum(r.get("verdict") == "inside" for r in rows),
               "level_ranges": {str(k): v for k, v in level_ranges().items()}}
    if rows:
        out.mkdir(parents=True, exist_ok=True)
        (out / "calibration.json").write_text(json.dumps(summary, indent=1))
        plot_calibration(rows, out / "calibration.png")
    return summary


def plot_calibration(rows: list[dict], path: Path) -> Path:
    """Success rate with its 95% interval per task, sorted, over the four level bands; colour = catalog level."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ranges = level_ranges()
    colours = {1: "#2e7d32", 2: "#1565c0", 3: "#ef6c00", 4: "#c62828"}
    rows = sorted(rows, key=lambda r: (r["catalog_level"], -r["success"], r["task"]))
    fig, ax = plt.subplots(figsize=(max(6.0, 0.45 * len(rows) + 2), 4.2))
    for level, (lo, hi) in ranges.items():
        if hi > lo:
            ax.axhspan(100 * lo, 100 * hi, color=colours[level], alpha=0.08, lw=0)
            ax.text(len(rows) - 0.4, 100 * (lo + hi) / 2, f"L{level}", va="center", ha="right", color=colours[level], fontsize=9)
    for i, r in enumerate(rows):
        lo, hi = r["ci95"]
        c = colours[r["catalog_level"]]
        ax.errorbar(i, 100 * r["success"], yerr=[[100 * (r["success"] - lo)], [100 * (hi - r["success"])]],
                    fmt="o" if r["agree"] else "X", color=c, ms=7, capsize=3)
        for seed_rate in (x["success"] for x in r.get("per_training_seed", {}).values()):
            if len(r.get("per_training_seed", {})) > 1:  # the spread over training seeds
                ax.plot(i + 0.18, 100 * seed_rate, "_", color=c, ms=8)
    ax.set_xticks(range(len(rows)))
    ax.set_xticklabels([r["task"] for r in rows], rotation=60, ha="right", fontsize=8)
    ax.set_ylabel("success on fresh seeds (%), 95% Wilson")
    ax.set_ylim(-3, 103)
    ax.set_xlim(-0.6, len(rows) - 0.4)
    protocols = ", ".join(sorted({str(r.get("protocol")) for r in rows}))
    ax.set_title(f"LadderFlow {protocols} calibration: colour = catalog level, x = level disagrees, "
                 "dashes = training seeds", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


# ---- `maniladder calibrate` -------------------------------------------------------------------------
def print_calibration(summary: dict, file=None) -> None:
    from maniladder_ms.table import print_table

    rows = []
    for r in sorted(summary["tasks"], key=lambda r: (r["catalog_level"], r["suite"], r["task"])):
        lo, hi = r["ci95"]
        spread = r.get("training_seed_spread") or {}
        seeds = f"{100 * spread['min']:.0f}-{100 * spread['max']:.0f}%" if spread.get("sd") is not None else "1 seed"
        rows.append((r["task"], r["suite"], f"L{r['catalog_level']}", f"{100 * r['success']:.0f}% ({r['successes']}/{r['episodes']})",
                     f"[{100 * lo:.0f}, {100 * hi:.0f}]", seeds, r["measured_level_text"], r.get("verdict", "?"),
                     r.get("purpose", "final")))
    print_table(("task", "suite", "catalog", "success", "95% Wilson", "training seeds", "measured", "interval vs band",
                 "seeds"), rows, file)
    print(f"\n{summary['n_inside']}/{summary['n_tasks']} tasks with their interval inside their catalog level's band "
          f"(LadderFlow {summary['protocol']}); {summary['n_agree']} with the point estimate in it.", file=file)


def add_parser(sub) -> None:
    from maniladder_ms.distributed import add_ray_argument

    cp = sub.add_parser(
        "calibrate", help="measure tasks' levels with the reference policy (LadderFlow): demos -> features -> train "
                          "-> evaluate",
        description=__doc__.split("\n\n")[0])
    sel = cp.add_mutually_exclusive_group(required=True)
    sel.add_argument("--level", type=int, choices=(1, 2, 3, 4))
    sel.add_argument("--suite", help="e.g. L1-rigid-SG")
    sel.add_argument("--tasks", help="comma-separated task ids")
    cp.add_argument("--purpose", choices=sorted(SEED_SETS), default="final",
                    help="final: the numbers that place tasks (3 training seeds, final seed set); development: for "
                         "decisions while refining (1 training seed, development seed set)")
    cp.add_argument("--work", type=Path, default=Path("runs/calibration/work"),
                    help="work folder: demos, features, checkpoints, episodes, per task version; a re-run resumes it "
                         "(default runs/calibration/work)")
    cp.add_argument("--out", type=Path, default=Path("runs/calibration/results"),
                    help="results folder (default runs/calibration/results; the committed results are docs/calibration)")
    cp.add_argument("--replace", action="store_true",
                    help="overwrite a result file in --out that holds another protocol's or task version's result")
    cp.add_argument("--demos", type=Path, help="folder of existing demos (<task>/trajectory.none.<mode>...h5) to use")
    cp.add_argument("--device", default="cpu", help="torch device for encoding and training (cpu, cuda); recorded")
    cp.add_argument("--renderer", choices=("cpu", "gpu"), default="cpu",
                    help="render backend of the demo frames and evaluation episodes (default cpu, lavapipe: the same "
                         "pixels on every machine); recorded")
    cp.add_argument("--workers", type=int, default=1, help="tasks calibrated in parallel processes")
    add_ray_argument(cp)
    cp.add_argument("--record", type=Path,
                    help="append each task's result to its calibration record DIR/<task>.json (the committed records: "
                         "docs/calibration/records; `maniladder show TASK` prints them)")
    cp.add_argument("--change", help="with --record: what changed in the task since its last recorded run, and why "
                                     "(required when the task's version changed)")
    cp.add_argument("--extra-round", action="store_true",
                    help="with --record: allow a development round past the loop's limit of 4 (with --change)")
    cp.add_argument("--revalidate", action="store_true",
                    help="train nothing: check each task's result in --out, measured on an earlier version of the "
                         "task, against the current one (own parts unchanged since its commit, its demos regenerated "
                         "bit-identical to those it was trained on: the result's demos_digest, or for an older result "
                         "the demos in --work), and if they match mark it as standing for the current version (and "
                         "in --record's record)")
    cp.add_argument("--videos", type=int, default=0, metavar="K",
                    help="film the first K evaluation episodes of each training seed (as `maniladder eval --videos`: "
                         "<work>/<task>/<version>/seed_<n>/<purpose>/videos/); only evaluations run now; default 0")
    cp.add_argument("--quiet", action="store_true", help="no progress bars")
    cp.set_defaults(func=cmd_calibrate)


def cmd_calibrate(args) -> int:
    import sys

    from maniladder_ms.evaluation.runner import select_tasks

    names = [t.strip() for t in args.tasks.split(",") if t.strip()] if args.tasks else None
    specs, skipped = select_tasks(default_catalog(), names, args.level, args.suite)
    if not specs:
        raise ValueError(f"no implemented task to calibrate in {args.suite or f'level {args.level}'}")
    if skipped:
        print(f"skipping {len(skipped)} task(s) not implemented yet: {', '.join(skipped)}", file=sys.stderr)
    tasks = [s.id for s in specs]
    if args.revalidate:
        return _revalidate(tasks, args)
    if args.device.startswith("cuda"):
        import torch

        if not torch.cuda.is_available():
            raise ValueError(f"--device {args.device}: torch sees no CUDA device here")
    if args.record:  # the record's rules are checked before any work starts
        from maniladder_ms.provenance import task_hash

        from .records import check_run

        if args.extra_round and not args.change:
            raise ValueError("--extra-round needs --change saying why the task needs another development round")
        for s in specs:
            check_run(args.record, s.id, task_hash(s.id), PROTOCOL_VERSION, args.purpose, LadderFlowConfig().as_dict(),
                      args.change, args.extra_round)
    by_id = {s.id: s for s in specs}
    record_one = (lambda r: _record_results([by_id[r["task"]]], args)) if args.record else None
    try:
        summary = calibrate(tasks, args.work, args.out, demos_dir=args.demos, device=args.device,
                            workers=args.workers, progress=not args.quiet,
                            protocol=CalibrationProtocol(purpose=args.purpose), renderer=args.renderer,
                            replace=args.replace, ray_address=args.ray, on_result=record_one, videos=args.videos)
    finally:  # each task is recorded as it finishes; this records those of an earlier, killed run (adds nothing twice)
        if args.record:
            _record_results(specs, args)
    print()
    print_calibration(summary)
    print(f"\nresults in {args.out}/ (<task>.json, calibration.json, calibration.png); `maniladder report {args.out}`")
    return 0


def _revalidate(tasks: list[str], args) -> int:
    """`calibrate --revalidate`: `revalidate.revalidate_folder` over the tasks' results in --out; with --record the
    equivalent versions go into the record's entries of the measured version."""
    from .records import add_equivalent
    from .revalidate import revalidate_folder

    rows = revalidate_folder(args.out, args.work, tasks, progress=not args.quiet)
    if args.record:
        for row in rows:
            if row["status"] == "equivalent":
                add_equivalent(args.record, row["result"])
    return 0 if all(row["status"] in ("current", "equivalent") for row in rows) else 1


def _record_results(specs, args) -> None:
    from maniladder_ms.provenance import task_hash

    from .records import load_record, record_run

    for s in specs:
        path = Path(args.out) / f"{s.id}.json"
        if not path.is_file():
            continue
        r = json.loads(path.read_text())
        if (r.get("task_hash"), r.get("purpose"), r.get("protocol")) == (task_hash(s.id), args.purpose, PROTOCOL_VERSION):
            before = len(load_record(args.record, s.id)["entries"])
            record = record_run(args.record, r, dict(s.params), args.change, args.extra_round)
            if len(record["entries"]) > before:
                print(f"{s.id}: recorded as entry {len(record['entries'])} of {Path(args.record) / (s.id + '.json')}")


def ladder_run(rows: list[dict], name: str) -> dict:
    """Calibration results as an evaluation run ({"name", "summary"}: `evaluation.stats.summarize` of their
    episodes), so the ladder's suite and level means, bootstrap intervals and figures are the evaluation report's."""
    from maniladder_ms.evaluation.stats import summarize

    records = [{"task": r["task"], "success": k < r["successes"], "steps": r.get("mean_steps") or 0}
               for r in rows for k in range(r["episodes"])]
    return {"name": name, "summary": summarize(records)}


def print_ladder(summary: dict, rows: list[dict], file=None) -> None:
    """Level means (catalog levels) with their 95% bootstrap intervals, whether adjacent levels' intervals are
    apart, and the agreement table: catalog level against measured level."""
    levels = {int(k): v for k, v in summary["levels"].items() if v["mean"] is not None}
    print("\nlevel means over the measured tasks (catalog levels; mean of suite means, 95% bootstrap over episodes):",
          file=file)
    for lv, v in sorted(levels.items()):
        lo, hi = v["ci"]
        print(f"  L{lv}: {100 * v['mean']:.0f}% [{100 * lo:.0f}, {100 * hi:.0f}] over {v['n_tasks']} of "
              f"{v['catalog_tasks']} tasks", file=file)
    for lv in sorted(levels):
        if lv + 1 in levels:
            apart = levels[lv]["ci"][0] > levels[lv + 1]["ci"][1]
            print(f"  L{lv} above L{lv + 1} with intervals apart: {'yes' if apart else 'no'}", file=file)
    measured = sorted({r["measured_level"] for r in rows})
    print("\nagreement (rows: catalog level; columns: measured level, 0 = easier than L1):", file=file)
    print("        " + "".join(f"{'M' + str(m):>6}" for m in measured), file=file)
    for lv in sorted({r["catalog_level"] for r in rows}):
        counts = [sum(r["catalog_level"] == lv and r["measured_level"] == m for r in rows) for m in measured]
        print(f"  L{lv}    " + "".join(f"{c:>6}" for c in counts), file=file)


def fig_scores(rows: list[dict]) -> bytes:
    """Success per task against each catalog difficulty score (C_geom, C_proc, C_perc) and the demos' mean
    length; colour = catalog level."""
    from maniladder_ms.evaluation.report import LEVEL_COLORS, _plt, _png

    plt = _plt()
    catalog = default_catalog()
    panels = [(k, lambda r, k=k: catalog.get(r["task"]).scores[k]) for k in ("C_geom", "C_proc", "C_perc")]
    panels.append(("demo length (steps)", lambda r: r.get("demo_mean_steps")))
    fig, axes = plt.subplots(1, len(panels), figsize=(3.0 * len(panels), 2.8), sharey=True)
    for ax, (name, value) in zip(axes, panels):
        for i, r in enumerate(rows):
            x = value(r)
            if x is None:
                continue
            jitter = 0.07 * (i % 5 - 2) if name.startswith("C_") else 0.0  # integer scores: points side by side
            ax.plot(x + jitter, 100 * r["success"], "o", color=LEVEL_COLORS[r["catalog_level"]], ms=5, alpha=0.8)
        ax.set_xlabel(name, fontsize=9)
    axes[0].set_ylabel("success (%)")
    fig.suptitle("success against the catalog's scores (colour = catalog level)", fontsize=10)
    fig.tight_layout()
    return _png(fig)


def write_calibration_report(folder: Path, out: Optional[Path] = None) -> Path:
    """`maniladder report <calibration folder>`: per protocol in the folder (newest first), the table, the level
    means and agreement table, and the figures (per task against the bands, suite means by level, level means,
    success against the difficulty scores) as one HTML page (`report/report.html`); rows that no longer measure
    their task as built are marked stale. The development runs in the folder's `development/` (the ladder's
    decisions while tasks are refined) follow their protocol's results as sections of their own, labelled so: they
    place no task."""
    import base64
    import html
    import io

    from maniladder_ms.evaluation.report import fig_grid, fig_levels

    folder = Path(folder)
    rows = load_results(folder, protocol=None)
    development = folder / DEVELOPMENT_FOLDER
    dev_rows = load_results(development, protocol=None) if development.is_dir() else []
    if not rows and not dev_rows:
        raise ValueError(f"{folder} holds no calibration results (<task>.json)")
    if rows:
        write_summary(folder)
    out = Path(out) if out else folder / "report"
    out.mkdir(parents=True, exist_ok=True)
    sections, text = [], io.StringIO()
    dev_kind = (f" development runs in {DEVELOPMENT_FOLDER}/", "; one training seed on the development seed set: "
                "decisions while a task is refined, not the numbers that place it")
    # newest protocol first; within one, the folder's own results before its development runs
    sections_of = sorted({(str(r.get("protocol")), 0) for r in rows} | {(str(r.get("protocol")), 1) for r in dev_rows},
                         key=lambda pk: (pk[0], -pk[1]), reverse=True)
    for protocol, is_dev in sections_of:
        kind, note = dev_kind if is_dev else ("", "")
        mine = [r for r in (dev_rows if is_dev else rows) if str(r.get("protocol")) == protocol]
        summary = {"protocol": protocol, "tasks": mine, "n_tasks": len(mine),
                   "n_agree": sum(r["agree"] for r in mine), "n_inside": sum(r.get("verdict") == "inside" for r in mine)}
        buf = io.StringIO()
        label = ("current protocol" if protocol == PROTOCOL_VERSION
                 else f"superseded by {PROTOCOL_VERSION}: not comparable") + note
        title = f"LadderFlow {protocol}{kind} ({label})"
        print(title, file=buf)
        print_calibration(summary, buf)
        stale = [(r["task"], why) for r in mine if (why := stale_reason(r))]
        for task, why in stale:
            print(f"STALE {task}: {why}", file=buf)
        run = ladder_run(mine, f"LadderFlow {protocol}{kind}")
        print_ladder(run["summary"], mine, buf)
        png_path = out / f"calibration_{protocol}{'_development' if kind else ''}.png"
        plot_calibration(mine, png_path)
        figures = [("success per task against the level bands", png_path.read_bytes()),
                   ("suite means by level (the paper's Table 3 layout)", fig_grid([run])),
                   ("level means with 95% bootstrap intervals", fig_levels([run])),
                   ("success against the catalog's difficulty scores", fig_scores(mine))]
        imgs = "".join(f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{base64.b64encode(png).decode()}">'
                       for alt, png in figures)
        sections.append(f"<h2>{html.escape(title)}</h2>{imgs}<pre>{html.escape(buf.getvalue())}</pre>")
        text.write(buf.getvalue() + "\n")
    page = (f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>ManiLadder calibration</title></head><body>'
            f"<h1>ManiLadder calibration</h1>{''.join(sections)}</body></html>")
    path = out / "report.html"
    path.write_text(page, encoding="utf-8")
    print(text.getvalue())
    return path
