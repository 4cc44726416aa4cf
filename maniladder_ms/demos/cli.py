"""`maniladder demos generate | verify | resample | stats | export | copy-meta`."""

from __future__ import annotations

import json
import sys
from dataclasses import asdict
from pathlib import Path

from maniladder_ms.catalog import INSTRUCTION_MODES
from maniladder_ms.distributed import add_ray_argument
from maniladder_ms.solvers import JOINT_TARGET_MODES

from .lerobot import DEFAULT_FPS


def _selected_tasks(args):
    from maniladder_ms.catalog import default_catalog

    cat = default_catalog()
    if args.task:
        specs = [cat.get(args.task)]
    else:
        specs = cat.filter(level=args.level, suite=args.suite)
    missing = [s.id for s in specs if not s.implemented]
    if args.task and missing:
        raise ValueError(f"task {args.task} is in the catalog but not implemented yet")
    if missing:
        print(f"skipping {len(missing)} tasks not implemented yet", file=sys.stderr)
    return [s for s in specs if s.implemented]


def cmd_generate(args) -> int:
    from .recording import default_control_modes, generate

    if not (args.task or args.level or args.suite):
        raise ValueError("name a task, or --level N / --suite S")
    for spec in _selected_tasks(args):
        for mode in args.control_mode or default_control_modes(spec.id):
            r = generate(spec.id, args.num, args.out, seed=args.seed, control_mode=mode, obs_mode=args.obs_mode,
                         workers=args.workers, overwrite=args.overwrite, instructions=args.instructions,
                         ray_address=args.ray)
            print(f"{r.task_id} [{mode}]: {r.kept} demos -> {r.path}  "
                  f"(solver success {r.success_rate:.0%} over {len(r.attempts)} seeds)")
    return 0


def _summary_line(path, checks) -> str:
    ok = sum(c.success_from_actions and c.success_from_states for c in checks)
    drift = max((c.max_drift for c in checks), default=0.0)
    lines = [f"{path}: {ok}/{len(checks)} episodes replay to success ({ok / max(len(checks), 1):.0%}); "
             f"max state drift {drift:.2e}"]
    lines += [f"  episode {c.episode_id} (seed {c.seed}): from actions {c.success_from_actions}, "
              f"from states {c.success_from_states}, drift {c.max_drift:.2e}"
              for c in checks if not (c.success_from_actions and c.success_from_states)]
    return "\n".join(lines)


def cmd_verify(args) -> int:
    from .verify import verify

    worst = 0
    report = []
    for path in args.paths:
        checks = verify(Path(path))
        print(_summary_line(path, checks))
        report += [dict(file=str(path), **asdict(c)) for c in checks]
        ok = sum(c.success_from_actions and c.success_from_states for c in checks)
        drift = max((c.max_drift for c in checks), default=0.0)
        if ok / max(len(checks), 1) < args.min_success or (args.max_drift is not None and drift > args.max_drift):
            worst = 1
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=2))
    return worst


def cmd_resample(args) -> int:
    from maniladder_ms.paths import REPO_DIR

    from .resample import resample, sample_files

    root = args.root or (REPO_DIR / "demos")
    files = sample_files(root, args.tasks or None)
    if not args.yes:
        print("re-recording replaces these files:\n  " + "\n  ".join(map(str, files)))
        if not sys.stdin.isatty():
            raise ValueError("not asking on a non-interactive input: pass --yes to replace the files")
        if input(f"replace {len(files)} demo files? [y/N] ").strip().lower() not in ("y", "yes"):
            print("nothing replaced")
            return 1
    results = resample(files, seed=args.seed, workers=args.workers)
    for r in results:
        print(("replaced " if r.ok else "KEPT the old file (new recording does not replay): ")
              + _summary_line(r.path, r.checks))
    return 0 if all(r.ok for r in results) else 1


def cmd_stats(args) -> int:
    from maniladder_ms.table import print_table

    from .stats import dataset_stats, plot_stats

    rows = dataset_stats(args.root)
    if not rows:
        raise ValueError(f"no demo files under {args.root}")
    print_table(
        ("task", "level", "control mode", "demos", "length mean", "min", "max", "horizon", "solver success"),
        [(r["task"], r["level"], r["control_mode"], r["demos"], f"{r['mean_len']:.0f}", r["min_len"], r["max_len"],
          r["horizon"], f"{r['solver_success']:.0%}") for r in rows],
    )
    png = plot_stats(rows, args.png or Path(args.root) / "stats.png")
    print(f"wrote {png}")
    return 0


def cmd_export(args) -> int:
    from .lerobot import export_lerobot

    cameras = [c for c in (args.cameras or "").split(",") if c] or None
    r = export_lerobot(args.path, args.out, cameras=cameras, fps=args.fps, overwrite=args.overwrite,
                       vcodec=args.vcodec)
    print(f"wrote a LeRobot v3.0 dataset of {r.episodes} episodes, {r.frames} frames, "
          f"cameras {', '.join(r.cameras)}, {len(r.tasks)} task string(s) -> {r.out}")
    return 0


def cmd_copy_meta(args) -> int:
    from .metadata import copy_metadata

    n = copy_metadata(args.source, args.converted)
    print(f"{args.converted}: {n} episodes given their instruction from {args.source}; env id, instructions, "
          "solver and source fields restored")
    return 0


def add_parser(sub):
    demos = sub.add_parser("demos", help="scripted demonstrations: generate, verify, resample, stats, export, "
                                         "copy-meta")
    dsub = demos.add_subparsers(dest="demos_command", required=True)

    gen = dsub.add_parser("generate", help="record successful solver episodes as ManiSkill h5 + json")
    gen.add_argument("task", nargs="?", help="task id (or use --level / --suite)")
    gen.add_argument("--level", type=int)
    gen.add_argument("--suite")
    gen.add_argument("--num", type=int, default=20, help="successful demos per task (default 20)")
    gen.add_argument("--out", type=Path, default=Path("demos"))
    gen.add_argument("--seed", type=int, default=0, help="first seed tried")
    gen.add_argument("--obs-mode", default="none", help="obs recorded with the demo (default none: convert later)")
    gen.add_argument("--control-mode", action="append", choices=JOINT_TARGET_MODES,
                     help="repeatable, one dataset file per mode; default the task's solver's own (first) mode "
                          "(`maniladder show TASK` names it)")
    gen.add_argument("--workers", type=int, default=1, help="processes")
    add_ray_argument(gen)
    gen.add_argument("--overwrite", action="store_true", help="replace an existing dataset file")
    gen.add_argument("--instructions", choices=INSTRUCTION_MODES, default="canonical",
                     help="the language instruction each episode records: the task's canonical one (default), "
                          "or one of it and its paraphrases drawn from the episode seed")
    gen.set_defaults(func=cmd_generate)

    ver = dsub.add_parser("verify", help="replay demos from actions and env states; non-zero exit below threshold")
    ver.add_argument("paths", nargs="+", type=Path, help="demo .h5 files")
    ver.add_argument("--min-success", type=float, default=1.0, help="fraction of episodes that must replay to success")
    ver.add_argument("--max-drift", type=float, help="fail if the action replay drifts further from the states")
    ver.add_argument("--json", type=Path, help="write every episode's result and state drift to this file")
    ver.set_defaults(func=cmd_verify)

    rs = dsub.add_parser("resample", help="re-record committed demo files after a physics-affecting change "
                                          "(same files, control modes and episode counts)")
    rs.add_argument("tasks", nargs="*", help="task ids (default: every task folder under --root)")
    rs.add_argument("--root", type=Path, help="demo folder (default: the checkout's demos/)")
    rs.add_argument("--seed", type=int, default=0, help="first seed tried (default 0, as the samples were made)")
    rs.add_argument("--workers", type=int, default=1, help="processes")
    rs.add_argument("--yes", action="store_true", help="replace the files without asking")
    rs.set_defaults(func=cmd_resample)

    st = dsub.add_parser("stats", help="per task demo counts, lengths and solver success; writes a PNG")
    st.add_argument("root", type=Path, nargs="?", default=Path("demos"))
    st.add_argument("--png", type=Path, help="plot path (default <root>/stats.png)")
    st.set_defaults(func=cmd_stats)

    ex = dsub.add_parser("export", help="write demos as a LeRobot v3.0 dataset (images rendered from the recorded "
                                        "env states)")
    ex.add_argument("path", type=Path, help="a demo .h5 file, or a folder of them (one embodiment and control mode)")
    ex.add_argument("--format", choices=("lerobot",), required=True, help="dataset format (lerobot: LeRobot v3.0)")
    ex.add_argument("--out", type=Path, required=True, help="dataset folder (must be missing or empty)")
    ex.add_argument("--cameras", help="camera uids, comma-separated, e.g. front_camera,hand_camera "
                                      "(default: all the task's cameras)")
    ex.add_argument("--fps", type=int, default=DEFAULT_FPS, help=f"frame rate of the timestamps and videos (default "
                                                                 f"{DEFAULT_FPS}, the tasks' control frequency)")
    ex.add_argument("--vcodec", choices=("libsvtav1", "libx264"), default="libsvtav1",
                    help="video encoder (default libsvtav1: AV1 as LeRobot writes; libx264: H.264)")
    ex.add_argument("--overwrite", action="store_true", help="replace an existing LeRobot dataset in --out")
    ex.set_defaults(func=cmd_export)

    cm = dsub.add_parser("copy-meta", help="after ManiSkill's replay_trajectory converted a demo: copy each episode's "
                                           "instruction (matched by episode seed), the env id's maniladder_ms: prefix "
                                           "and the other fields the conversion drops from the source's json onto "
                                           "the converted file's json")
    cm.add_argument("source", type=Path, help="the demo .h5 the conversion read")
    cm.add_argument("converted", type=Path, help="the .h5 replay_trajectory wrote (its .json is updated in place)")
    cm.set_defaults(func=cmd_copy_meta)
