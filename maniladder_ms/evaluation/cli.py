"""`maniladder eval` and `maniladder report`: `add_parsers(subparsers)` adds both to the `maniladder`
command; `python -m maniladder_ms.evaluation.cli eval|report ...` runs them standalone."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from maniladder_ms.catalog import EMBODIMENTS, INSTRUCTION_MODES, LEVELS, OBJECT_PROPERTIES, CatalogError, UnknownTaskError

from maniladder_ms.distributed import DistributedError, add_ray_argument
from maniladder_ms.table import print_table

from .policies import PolicyError, policy_label
from .results import ALL_CAMERAS, ResultsError, run_cameras

ERRORS = (PolicyError, ResultsError, CatalogError, UnknownTaskError, ValueError, NotImplementedError, DistributedError)


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.0f}"


def print_summary(summary: dict, file=None):
    file = file or sys.stdout
    rows = [("task", "level", "suite", "success", "95% Wilson", "episodes", "mean steps", "s/episode")]
    for tid, t in summary["tasks"].items():
        rows.append((tid, str(t["level"]), t["suite"], f"{100 * t['rate']:.0f}%",
                     f"[{_pct(t['ci'][0])}, {_pct(t['ci'][1])}]", str(t["episodes"]),
                     f"{t['mean_steps']:.0f}", f"{t['mean_wall_s']:.2f}"))
    print_table(rows[0], rows[1:], file)
    print(file=file)
    cols = [f"{p[:3]}-{e}" for p in OBJECT_PROPERTIES for e in EMBODIMENTS]
    rows = [("level", *cols, "level mean", "threshold", "coverage")]
    for level in LEVELS:
        cells = []
        for p in OBJECT_PROPERTIES:
            for e in EMBODIMENTS:
                s = summary["suites"][f"L{level}-{p}-{e}"]
                cells.append(_pct(s["mean"]))
        lv = summary["levels"][str(level)]
        ci = f" [{_pct(lv['ci'][0])}, {_pct(lv['ci'][1])}]" if lv["ci"] else ""
        rows.append((f"L{level}", *cells, _pct(lv["mean"]) + ci, lv["threshold_text"], f"{lv['n_tasks']}/{lv['catalog_tasks']} tasks"))
    print_table(rows[0], rows[1:], file)
    if summary.get("skipped"):
        by_reason: dict = {}
        for k, v in summary["skipped"].items():
            by_reason.setdefault(v, []).append(k)
        parts = [f"{reason}: " + (", ".join(ids) if len(ids) <= 6 else f"{len(ids)} tasks") for reason, ids in by_reason.items()]
        print(f"\nskipped {len(summary['skipped'])} task(s) (not evaluated): " + "; ".join(parts), file=file)
    print(f"\n{summary['ladder']['text']}", file=file)
    from maniladder_ms.catalog import default_catalog
    from maniladder_ms.levels import levels_note

    print(f"(the levels tasks count towards: {levels_note(default_catalog().get(t) for t in summary['tasks'])})", file=file)


def cmd_eval(args) -> int:
    from .runner import evaluate

    tasks = [t.strip() for t in args.tasks.split(",") if t.strip()] if args.tasks else None
    out = args.out or Path("results") / policy_label(args.policy)
    summary = evaluate(args.policy, out, tasks=tasks, level=args.level, suite=args.suite, episodes=args.episodes,
                       seed=args.seed, obs_mode=args.obs_mode, workers=args.workers, progress=not args.quiet,
                       instructions=args.instructions, cameras=args.cameras, ray_address=args.ray, videos=args.videos)
    print_summary(summary)
    if run_cameras(summary["manifest"]) != ALL_CAMERAS:
        print(f"\ncameras the policy could see (--cameras): {run_cameras(summary['manifest'])}")
    print(f"\nresults in {out}/ (episodes.jsonl, summary.json); `maniladder report {out}` renders the report")
    return 0


def cmd_report(args) -> int:
    from maniladder_ms.policy.calibrate import load_results, write_calibration_report

    from .report import write_report

    if len(args.results) == 1 and args.results[0].is_dir() and load_results(args.results[0], protocol=None):  # `maniladder calibrate` results
        html = write_calibration_report(args.results[0], out=args.out)
    else:
        html = write_report(args.results, out=args.out, title=args.title, mixed_cameras=args.mixed_cameras)
    print(f"wrote {html}")
    return 0


def add_parsers(subparsers) -> None:
    """Add `eval` and `report` to the subparsers of the `maniladder` command (its `build_parser`)."""
    ev = subparsers.add_parser(
        "eval", help="evaluate a policy on the ladder under the fixed protocol",
        description="Evaluate a policy: per-task success with 95% Wilson intervals, Table 3 suite means, the ladder level.",
    )
    ev.add_argument("--policy", required=True,
                    help="random | solver | replay:<demo.h5 or folder> | module:attr | path/to/file.py:attr | "
                         "openpi://HOST:PORT (a served policy, docs/remote-policies.md)")
    sel = ev.add_mutually_exclusive_group()
    sel.add_argument("--level", type=int, choices=LEVELS)
    sel.add_argument("--suite", help="e.g. L1-rigid-SG")
    sel.add_argument("--tasks", help="comma-separated task ids, e.g. PickPlacePen,Stack6Blocks")
    ev.add_argument("--episodes", type=int, default=20, help="episodes per task (default 20)")
    ev.add_argument("--seed", type=int, default=0, help="evaluation seed set: episode k uses 1000000 + 10000*seed + k")
    ev.add_argument("--obs-mode", default="rgb",
                    help="rgb (default: 4 RGB cameras, no state) | rgb+state | any ManiSkill obs mode")
    ev.add_argument("--out", type=Path, help="results folder (default results/<policy>); re-running resumes it")
    ev.add_argument("--workers", type=int, default=1, help="worker processes (default 1)")
    add_ray_argument(ev)
    ev.add_argument("--instructions", choices=INSTRUCTION_MODES, default="canonical",
                    help="the language instruction the policy gets (ctx.instruction): the task's canonical one "
                         "(default), or per episode one of it and its paraphrases drawn from the episode seed")
    ev.add_argument("--cameras", help="the cameras the policy may see, comma-separated (e.g. front_camera, or "
                                      "front_camera,hand_camera); default all of each task's; recorded in the manifest")
    ev.add_argument("--videos", type=int, default=0, metavar="K",
                    help="film the first K episodes of each task: <out>/videos/<task>/ep<k>_seed<s>_<success|failure>.mp4 "
                         "(the render camera over the images the policy saw; default 0)")
    ev.add_argument("--quiet", action="store_true", help="no progress bar")
    ev.set_defaults(func=_guarded(cmd_eval))

    rp = subparsers.add_parser(
        "report", help="HTML report (+ PNGs) of one or more results folders; the first is the baseline",
    )
    rp.add_argument("results", nargs="+", type=Path,
                    help="results folders (or a folder holding several); two or more are compared to the first; "
                         "or one `maniladder calibrate` folder (docs/calibration)")
    rp.add_argument("--out", type=Path, help="report folder (default <first results>/report)")
    rp.add_argument("--title", default="ManiLadder evaluation report")
    rp.add_argument("--mixed-cameras", action="store_true",
                    help="compare runs whose policies saw different camera subsets (refused otherwise)")
    rp.set_defaults(func=_guarded(cmd_report))


def _guarded(cmd):
    """Bad input gives one clear line and exit status 2 (whichever main() calls the command)."""

    def run(args) -> int:
        try:
            return cmd(args)
        except ERRORS as e:
            print(f"maniladder {args.command}: error: {e}", file=sys.stderr)
            return 2

    run.__name__ = cmd.__name__
    return run


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="maniladder", description=__doc__)
    add_parsers(p.add_subparsers(dest="command", required=True))
    args = p.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
