"""`maniladder calibrate`: measure each task's level with the reference policy (LadderFlow, protocol v3).

Per task, five stages, each leaving its result in the task's work folder so that a killed run resumes
where it stopped (a stage whose output exists is not run again; a half-written output never exists):

1. demos     `demos` (20) solver demonstrations, seeds from 0, in the mode the task's solver drives
             (`demo_control_mode_for`); an existing demo file of that task/mode in `--demos` is used as is.
2. features  every `frame_stride`-th demo frame rendered from the policy's cameras (front, left, top;
             128x128 RGB) and encoded by the frozen encoder, cached as float16 (`features.npz`), with the
             demo's actions as absolute joint targets (`POLICY_CONTROL_MODE`, `demos.joint_targets`).
3. train     one LadderFlow policy on those features; a checkpoint after every `train_steps / checkpoints`
             steps (each holds the optimiser: training resumes from the last one).
4. select    every checkpoint evaluated on `selection_episodes` episodes of the selection seed set
             (`SELECTION_SEED_SET`); the best success rate wins, ties to the later checkpoint.
5. evaluate  the selected checkpoint on `episodes` fresh episodes (seed set `EVALUATION_SEED_SET`,
             disjoint from the selection seeds and from demo seeds): the success rate, its 95% Wilson
             interval and the measured level. The best selection rate is reported too, labelled: it is
             the paper's "best success during training" and biased upwards.

The measured level places the rate on the catalog's intervals (L1 [60, 85] %, L2 [20, 60) %, L3 (0, 20) %,
L4 0 %); above L1's interval it is 0, "easier than Level 1". It is compared with the task's catalog level and
a disagreement is flagged, never tuned away here.

Results: `<out>/<task>.json` per task, and `<out>/calibration.json` + `calibration.png` (success with its
interval per task against the level bands, coloured by catalog level) over every task in `<out>`;
`maniladder report <out>` renders them.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Optional, Sequence

from maniladder_ms.catalog import default_catalog

from .flow import PROTOCOL_VERSION, LadderFlowConfig

SELECTION_SEED_SET = 1  # `maniladder eval --seed 1`: episode k resets with seed 1,010,000 + k
EVALUATION_SEED_SET = 0  # the protocol's standard evaluation seeds: 1,000,000 + k
STAGES = ("demos", "features", "train", "select", "evaluate")
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
    checkpoints: int = 2  # evaluated at train_steps * k / checkpoints, k = 1..checkpoints
    selection_episodes: int = 10
    # 50 fresh episodes, not 20: 20 pin a rate to about +-20 points (LiftBottleHand: 10/10 on selection, 9/20 on
    # evaluation), too wide to tell 55 % (L2) from 65 % (L1); 50 give about +-13. Evaluation is the cheap
    # stage (2-8 s an episode against ~30 min of training), and a work folder evaluated on fewer episodes
    # resumes by adding the missing ones (`TaskCalibration.GROWABLE`)
    episodes: int = 50

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


def level_text(level: int) -> str:
    return "easier than L1 (above its band)" if level == 0 else f"L{level}"


class TaskCalibration:
    """The stages of one task in `work/<task>/`; `run()` does those not done yet and returns the result."""

    def __init__(self, task_id: str, work: Path, out: Path, demos_dir: Optional[Path] = None,
                 config: LadderFlowConfig = LadderFlowConfig(), protocol: CalibrationProtocol = CalibrationProtocol(),
                 device: str = "cpu", progress: bool = True, log=print):
        self.spec = default_catalog().get(task_id)
        if not self.spec.implemented:
            import maniladder_ms

            raise maniladder_ms.TaskNotImplementedError(f"task {task_id} is not implemented yet; it cannot be calibrated")
        self.config, self.protocol, self.device, self.progress, self.log = config, protocol, device, progress, log
        self.dir = Path(work) / task_id
        self.out = Path(out)
        self.demos_dir = Path(demos_dir) if demos_dir else self.dir / "demos"
        self.control_mode = POLICY_CONTROL_MODE
        self.demo_control_mode = demo_control_mode_for(task_id)
        self.timings_path = self.dir / "timings.json"

    # ---- bookkeeping -------------------------------------------------------------------------------
    def _timings(self) -> dict:
        return json.loads(self.timings_path.read_text()) if self.timings_path.is_file() else {}

    def _timed(self, stage: str, fn):
        t0 = time.perf_counter()
        out = fn()
        timings = self._timings()
        timings[stage] = round(timings.get(stage, 0.0) + time.perf_counter() - t0, 1)
        self.timings_path.write_text(json.dumps(timings, indent=1))
        return out

    # protocol fields that may differ on a resumed work folder: more evaluation episodes only add episodes
    # (the evaluation folder resumes); nothing trained or selected depends on them
    GROWABLE = ("episodes",)

    def _check_settings(self):
        """A work folder belongs to one configuration: resuming with another one would mix them."""
        settings = {"protocol": PROTOCOL_VERSION, "config": self.config.as_dict(), "calibration": self.protocol.as_dict(),
                    "control_mode": self.control_mode, "demo_control_mode": self.demo_control_mode}
        path = self.dir / "settings.json"
        if path.is_file():
            old = json.loads(path.read_text())
            fixed = [{**s, "calibration": {k: v for k, v in s.get("calibration", {}).items() if k not in self.GROWABLE}}
                     for s in (old, settings)]
            if fixed[0] != fixed[1]:
                raise ValueError(f"{self.dir} holds a calibration with other settings ({path}); "
                                 "give another --work folder or delete that one")
            before, now = (s.get("calibration", {}).get("episodes", 0) for s in (old, settings))
            if now < before:  # the evaluation folder keeps all it has: the result would count `before` episodes
                raise ValueError(f"{self.dir} was evaluated on {before} episodes; a calibration can add episodes, "
                                 f"not drop them (asked for {now})")
            if old != settings:
                path.write_text(json.dumps(settings, indent=1))
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
    def checkpoint_steps(self) -> list[int]:
        n = self.protocol.checkpoints
        return [self.config.train_steps * k // n for k in range(1, n + 1)]

    def checkpoint(self, step: int) -> Path:
        return self.dir / f"checkpoint_{step}.pt"

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

        encoder = make_encoder(self.config.encoder, grid=self.config.grid, device=self.device)
        cache_features(self.demo_h5, encoder, self.config.cameras, self.features_path, size=self.config.image_size,
                       progress=self.progress, stride=self.protocol.frame_stride, control_mode=self.control_mode)

    def stage_train(self):
        todo = [step for step in self.checkpoint_steps if not self.checkpoint(step).is_file()]
        if not todo:
            return
        from .features import load_features
        from .flow import LadderFlowTrainer

        episodes = load_features(self.features_path)[: self.protocol.demos]
        trainer = LadderFlowTrainer(self.config, episodes, device=self.device)
        done = [step for step in self.checkpoint_steps if step not in todo]
        if done:
            trainer.resume(self.checkpoint(max(done)))
        meta = {"task": self.spec.id, "control_mode": self.control_mode}
        for step in todo:
            losses = trainer.train(step - trainer.step_count, progress=self.progress)
            trainer.save(self.checkpoint(step), meta=dict(meta, final_loss=float(sum(losses[-100:]) / max(len(losses[-100:]), 1))))

    def _evaluate(self, step: int, folder: str, episodes: int, seed_set: int) -> dict:
        from maniladder_ms.evaluation.runner import evaluate

        from .evaluate import LadderFlowEvalPolicy

        policy = LadderFlowEvalPolicy(self.checkpoint(step))
        summary = evaluate(policy, self.dir / folder, tasks=[self.spec.id], episodes=episodes, seed=seed_set,
                           progress=self.progress, bootstrap=0)
        return summary["tasks"][self.spec.id]

    def stage_select(self) -> dict:
        path = self.dir / "selection.json"
        if path.is_file():
            return json.loads(path.read_text())
        rates = {step: self._evaluate(step, f"select_{step}", self.protocol.selection_episodes, SELECTION_SEED_SET)["rate"]
                 for step in self.checkpoint_steps}
        best = max(rates, key=lambda step: (rates[step], step))
        sel = {"selection_rates": {str(s): r for s, r in rates.items()}, "selected_step": best}
        path.write_text(json.dumps(sel, indent=1))
        return sel

    def stage_evaluate(self, sel: dict) -> dict:
        return self._evaluate(sel["selected_step"], "evaluate", self.protocol.episodes, EVALUATION_SEED_SET)

    # ---- all of it ---------------------------------------------------------------------------------
    def run(self) -> dict:
        self._check_settings()
        self._timed("demos", self.stage_demos)
        self._timed("features", self.stage_features)
        self._timed("train", self.stage_train)
        sel = self._timed("select", self.stage_select)
        return self.write_result(self._timed("evaluate", lambda: self.stage_evaluate(sel)), sel)

    def write_result(self, task: dict, sel: dict) -> dict:
        from maniladder_ms.demos.files import load_demo_json

        ranges = level_ranges()
        level = measured_level(task["rate"], ranges)
        demos = load_demo_json(self.demo_h5)["episodes"][: self.protocol.demos]
        result = {
            "task": self.spec.id, "suite": self.spec.suite, "catalog_level": self.spec.level,
            "successes": task["successes"], "episodes": task["episodes"], "success": task["rate"],
            "ci95": list(task["ci"]), "measured_level": level, "measured_level_text": level_text(level),
            "agree": level == self.spec.level,
            "best_selection_success": max(sel["selection_rates"].values()),
            "best_selection_success_note": "best success over checkpoints on the selection seeds (the paper's "
                                           "'best success during training'): biased upwards",
            "selection": sel, "control_mode": self.control_mode, "demo_control_mode": self.demo_control_mode,
            "horizon": self.spec.horizon,
            "demo_mean_steps": sum(e["elapsed_steps"] for e in demos) / max(len(demos), 1),
            "mean_steps": task["mean_steps"], "timings_s": self._timings(),
            "protocol": PROTOCOL_VERSION, "config": self.config.as_dict(), "calibration": self.protocol.as_dict(),
            "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        }
        path = self.out / f"{self.spec.id}.json"
        if path.is_file():  # a resume of a finished task: the committed result stays as it is (no new time stamp)
            old = json.loads(path.read_text())
            volatile = ("time", "timings_s")
            if {k: v for k, v in old.items() if k not in volatile} == \
                    json.loads(json.dumps({k: v for k, v in result.items() if k not in volatile})):
                return old
        self.out.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(result, indent=1))
        return result


def _calibrate_one(task_id: str, kwargs: dict) -> dict:
    import torch

    torch.set_num_threads(1)  # one task per process and core
    return TaskCalibration(task_id, **kwargs).run()


def calibrate(tasks: Sequence[str], work: Path, out: Path, demos_dir: Optional[Path] = None, device: str = "cpu",
              workers: int = 1, progress: bool = True, config: LadderFlowConfig = LadderFlowConfig(),
              protocol: CalibrationProtocol = CalibrationProtocol(), log=print) -> dict:
    """Calibrate `tasks` (resuming what `work` holds), then rewrite the summary of every result in `out`."""
    import concurrent.futures as cf
    import multiprocessing as mp

    kwargs = dict(work=Path(work), out=Path(out), demos_dir=demos_dir, config=config, protocol=protocol, device=device)
    for t in tasks:  # bad names and unbuilt tasks fail before any work starts
        TaskCalibration(t, **kwargs)
    failed = {}
    if workers <= 1:
        for t in tasks:
            t0 = time.perf_counter()
            r = TaskCalibration(t, progress=progress, log=log, **kwargs).run()
            log(_result_line(r, time.perf_counter() - t0))
    else:
        with cf.ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
            futures = {pool.submit(_calibrate_one, t, dict(kwargs, progress=False)): t for t in tasks}
            for fut in cf.as_completed(futures):
                try:
                    log(_result_line(fut.result()))
                except Exception as e:  # one task's failure leaves the others running
                    failed[futures[fut]] = f"{type(e).__name__}: {e}"
                    log(f"{futures[fut]}: FAILED {failed[futures[fut]]}")
    summary = write_summary(out)
    if failed:
        raise RuntimeError("calibration failed for " + "; ".join(f"{t} ({why})" for t, why in failed.items()))
    return summary


def _result_line(r: dict, wall: Optional[float] = None) -> str:
    lo, hi = r["ci95"]
    flag = "agrees" if r["agree"] else f"DISAGREES with catalog L{r['catalog_level']}"
    extra = f" ({wall / 60:.1f} min)" if wall else ""
    return (f"{r['task']}: {r['successes']}/{r['episodes']} = {100 * r['success']:.0f}% [{100 * lo:.0f}, {100 * hi:.0f}] "
            f"-> {r['measured_level_text']}, {flag}{extra}")


def load_results(out: Path) -> list[dict]:
    """The task results in `out` measured under this protocol (another protocol's numbers are not comparable)."""
    rows = []
    for p in sorted(Path(out).glob("*.json")):
        if p.name == "calibration.json":
            continue
        r = json.loads(p.read_text())
        if "measured_level" in r and r.get("protocol") == PROTOCOL_VERSION:
            rows.append(r)
    return rows


def write_summary(out: Path) -> dict:
    """`calibration.json` (the table) and `calibration.png` (the plot) over every task result in `out`."""
    out = Path(out)
    rows = load_results(out)
    cols = ("task", "suite", "catalog_level", "successes", "episodes", "success", "ci95", "measured_level",
            "measured_level_text", "agree", "best_selection_success", "demo_mean_steps", "timings_s")
    table = [{c: r[c] for c in cols} for r in rows]
    agree = sum(r["agree"] for r in rows)
    summary = {"protocol": PROTOCOL_VERSION, "tasks": table, "n_tasks": len(rows), "n_agree": agree,
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
    ax.set_xticks(range(len(rows)))
    ax.set_xticklabels([r["task"] for r in rows], rotation=60, ha="right", fontsize=8)
    ax.set_ylabel("success on fresh seeds (%), 95% Wilson")
    ax.set_ylim(-3, 103)
    ax.set_xlim(-0.6, len(rows) - 0.4)
    ax.set_title(f"LadderFlow {PROTOCOL_VERSION} calibration: colour = catalog level, x = level disagrees", fontsize=10)
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
        rows.append((r["task"], r["suite"], f"L{r['catalog_level']}", f"{100 * r['success']:.0f}% ({r['successes']}/{r['episodes']})",
                     f"[{100 * lo:.0f}, {100 * hi:.0f}]", r["measured_level_text"], "yes" if r["agree"] else "NO",
                     f"{100 * r['best_selection_success']:.0f}%"))
    print_table(("task", "suite", "catalog", "success", "95% Wilson", "measured", "agree?", "best sel.*"), rows, file)
    print(f"\n{summary['n_agree']}/{summary['n_tasks']} tasks measured at their catalog level. *best success over "
          "checkpoints on the selection seeds (the paper's 'best during training'): biased upwards.", file=file)


def add_parser(sub) -> None:
    cp = sub.add_parser(
        "calibrate", help="measure tasks' levels with the reference policy (LadderFlow): demos -> features -> train "
                          "-> select -> evaluate",
        description=__doc__.split("\n\n")[0])
    sel = cp.add_mutually_exclusive_group(required=True)
    sel.add_argument("--level", type=int, choices=(1, 2, 3, 4))
    sel.add_argument("--suite", help="e.g. L1-rigid-SG")
    sel.add_argument("--tasks", help="comma-separated task ids")
    cp.add_argument("--work", type=Path, default=Path("runs/calibration"),
                    help="work folder: demos, features, checkpoints, episodes; a re-run resumes it (default runs/calibration)")
    cp.add_argument("--out", type=Path, default=Path("docs/calibration"), help="results folder (default docs/calibration)")
    cp.add_argument("--demos", type=Path, help="folder of existing demos (<task>/trajectory.none.<mode>...h5) to use")
    cp.add_argument("--device", default="cpu", help="torch device for encoding and training (cpu, cuda)")
    cp.add_argument("--workers", type=int, default=1, help="tasks calibrated in parallel processes")
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
    if args.device.startswith("cuda"):
        import torch

        if not torch.cuda.is_available():
            raise ValueError(f"--device {args.device}: torch sees no CUDA device here")
    summary = calibrate(tasks, args.work, args.out, demos_dir=args.demos, device=args.device, workers=args.workers,
                        progress=not args.quiet)
    print()
    print_calibration(summary)
    print(f"\nresults in {args.out}/ (<task>.json, calibration.json, calibration.png); `maniladder report {args.out}`")
    return 0


def write_calibration_report(folder: Path, out: Optional[Path] = None) -> Path:
    """`maniladder report <calibration folder>`: the table and the plot as one HTML page (`report/report.html`)."""
    import base64
    import html
    import io

    folder = Path(folder)
    summary = write_summary(folder)
    if not summary["n_tasks"]:
        raise ValueError(f"{folder} holds no calibration results (<task>.json)")
    out = Path(out) if out else folder / "report"
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    print_calibration(summary, buf)
    png = base64.b64encode((folder / "calibration.png").read_bytes()).decode()
    page = (f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>ManiLadder calibration</title></head><body>'
            f"<h1>ManiLadder calibration (LadderFlow {PROTOCOL_VERSION})</h1>"
            f'<img alt="success per task against the level bands" src="data:image/png;base64,{png}">'
            f"<pre>{html.escape(buf.getvalue())}</pre></body></html>")
    path = out / "report.html"
    path.write_text(page, encoding="utf-8")
    print(buf.getvalue())
    return path
