"""`maniladder`: list the ladder, render a task, benchmark steps/s, demos, evaluation, calibration and reports."""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

from maniladder_ms.catalog import EMBODIMENTS, LEVELS, OBJECT_CLASSES, OBJECT_PROPERTIES, SKILLS, CatalogError, UnknownTaskError
from maniladder_ms.demos.cli import add_parser as add_demos_parser
from maniladder_ms.demos.files import DemoFileError
from maniladder_ms.distributed import DistributedError
from maniladder_ms.evaluation.cli import add_parsers as add_eval_parsers
from maniladder_ms.evaluation.serve import add_parser as add_serve_parser
from maniladder_ms.policy.calibrate import add_parser as add_calibrate_parser
from maniladder_ms.table import print_table


def _catalog():
    import maniladder_ms  # registers the implemented envs

    return maniladder_ms.default_catalog()


def cmd_list(args) -> int:
    cat = _catalog()
    tasks = cat.filter(
        level=args.level, suite=args.suite, embodiment=args.embodiment, skill=args.skill,
        object_class=args.object_class, implemented=True if args.implemented else None,
    )
    if args.summary:
        return _print_summary(cat, tasks, args.json)
    if args.json:
        print(json.dumps([t.as_dict() for t in tasks], indent=2))
        return 0
    if args.instructions:  # the canonical instruction instead of the metadata columns, to keep lines short
        print_table(("", "task", "suite", "instruction"),
                    [("*" if t.implemented else " ", t.id, t.suite, t.instruction) for t in tasks])
        print(f"\n{len(tasks)} tasks, {sum(t.implemented for t in tasks)} implemented (*); "
              "`maniladder show TASK` lists a task's paraphrases")
        return 0
    from maniladder_ms.levels import level_label, levels_note

    header = ("", "task", "level", "suite", "object", "skills", "horizon", "Cg/Cp/Cv")
    rows = [
        ("*" if t.implemented else " ", t.id, level_label(t), t.suite, t.object_class, ",".join(t.skills),
         str(t.horizon), "{C_geom}/{C_proc}/{C_perc}".format(**t.scores))
        for t in tasks
    ]
    print_table(header, rows)
    print(f"\n{len(tasks)} tasks, {sum(t.implemented for t in tasks)} implemented (*); {levels_note(tasks)}")
    return 0


def _print_summary(cat, tasks, as_json: bool) -> int:
    per_suite = Counter(t.suite for t in tasks)
    done_suite = Counter(t.suite for t in tasks if t.implemented)
    if as_json:
        out = {
            "catalog": len(tasks), "implemented": sum(done_suite.values()),
            "suites": {s: {"catalog": per_suite[s], "implemented": done_suite[s]} for s in cat.suites() if per_suite[s]},
        }
        print(json.dumps(out, indent=2))
        return 0
    cols = [f"{p[:3]}-{e}" for p in OBJECT_PROPERTIES for e in EMBODIMENTS]
    rows = []
    for level in LEVELS:
        cells = []
        for p in OBJECT_PROPERTIES:
            for e in EMBODIMENTS:
                s = f"L{level}-{p}-{e}"
                cells.append(f"{done_suite[s]}/{per_suite[s]}" if per_suite[s] else "-")
        lv = [t for t in tasks if t.level == level]
        rows.append((f"L{level}", *cells, f"{sum(t.implemented for t in lv)}/{len(lv)}"))
    print_table(("level", *cols, "total"), rows)
    print(f"\nimplemented / catalog: {sum(done_suite.values())} / {len(tasks)} tasks")
    return 0


def cmd_show(args) -> int:
    """Where a task lives: its catalog row (family, params, rendered rule), its env class and solver files."""
    from mani_skill.utils.registration import REGISTERED_ENVS

    from maniladder_ms.layout import format_breadth, object_breadths
    from maniladder_ms.levels import level_label, levels_note

    spec = _catalog().get(args.task)
    rows = [("task", f"{spec.id} ({spec.suite}, horizon {spec.horizon})"),
            ("level", f"{level_label(spec)}: {levels_note([spec])}"), ("family", spec.family),
            ("description", spec.description), ("success", spec.success), ("instruction", spec.instruction)]
    rows += [(f"paraphrase {i}", p) for i, p in enumerate(spec.paraphrases, 1)]
    rows += [(f"param {k}", str(v)) for k, v in spec.params.items()]
    objects = object_breadths(dict(spec.params), spec.layout_derived)
    if objects:  # the breadth of its layout params (docs/calibration/layout-policy.md)
        rows.append(("layout", format_breadth(objects)))
    if spec.implemented:
        from maniladder_ms.solvers import solver_for

        cls = REGISTERED_ENVS[spec.env_id].cls
        rows.append(("env class", f"{cls.__module__}.{cls.__qualname__}  ({_source_line(cls)})"))
        try:
            solver = solver_for(spec.id)
            rows.append(("solver", f"{solver.run.__qualname__} in {solver.control_mode}  ({_source_line(solver.run)})"))
        except KeyError:
            rows.append(("solver", "none registered"))
    else:
        rows.append(("env class", "not built yet"))
    rows.append(("catalog row", _catalog_line(spec.id)))
    from maniladder_ms.policy.records import COMMITTED_RECORDS, load_record, record_lines

    lines = record_lines(load_record(COMMITTED_RECORDS, spec.id))  # the rounds that refined and placed it
    rows.append(("calibration", f"{len(lines)} recorded run(s) ({COMMITTED_RECORDS / (spec.id + '.json')})" if lines
                 else "no recorded run (maniladder calibrate --record docs/calibration/records)"))
    rows += [("", line) for line in lines]
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")
    return 0


def _catalog_line(task_id: str) -> str:
    from importlib import resources

    lines = resources.files("maniladder_ms").joinpath("data/task_catalog.yaml").read_text().splitlines()
    number = next(i for i, line in enumerate(lines, 1) if line == f"- id: {task_id}")
    return f"maniladder_ms/data/task_catalog.yaml:{number}"


def _source_line(obj) -> str:
    import inspect

    path = Path(inspect.getsourcefile(obj))
    try:
        path = path.relative_to(Path.cwd())
    except ValueError:
        pass
    return f"{path}:{inspect.getsourcelines(obj)[1]}"


def _showcases() -> dict[str, str]:
    from maniladder_ms.deformables.showcase import SHOWCASE_ENV_IDS

    return SHOWCASE_ENV_IDS


def _robots() -> tuple[str, ...]:
    from maniladder_ms.agents import AGENT_UIDS

    return AGENT_UIDS


def _check_choice(kind: str, value: str, choices) -> None:
    if value not in choices:
        raise ValueError(f"unknown {kind} {value!r}; choose from: {', '.join(choices)}")


def cmd_render(args) -> int:
    from maniladder_ms import render

    if [args.task, args.robot, args.scene].count(None) != 2:
        raise ValueError("render takes exactly one of: a task id, --robot UID, --scene KIND")
    if args.solved and args.task is None:
        raise ValueError("--solved shows a task after its scripted solver: give a task id")
    if args.robot:
        _check_choice("robot", args.robot, _robots())
        path = render.render_agent(args.robot, args.seed, args.out or Path(f"agent_{args.robot}.png"), size=args.size)
    elif args.scene:
        from maniladder_ms.deformables.showcase import render_showcase

        _check_choice("scene", args.scene, sorted(_showcases()))
        path = render_showcase(args.scene, args.out or Path(f"scene_{args.scene}.png"), seed=args.seed, size=args.size)
    else:
        spec = _catalog().get(args.task)
        out = args.out or Path(f"{spec.id}_seed{args.seed}.png")
        if args.visual_seed is not None and not args.domain_randomization:
            raise ValueError("--visual-seed picks the look of domain randomisation: add --dr")
        path = render.render_task(spec.id, args.seed, out, domain_randomization=args.domain_randomization,
                                  size=args.size, visual_seed=args.visual_seed, solved=args.solved)
    print(f"wrote {path}")
    return 0


def _expand(kind: str, values: list[str], choices) -> list[str]:
    """`all` -> every choice; otherwise checked values."""
    if values == ["all"]:
        return list(choices)
    for v in values:
        _check_choice(kind, v, choices)
    return values


def cmd_bench(args) -> int:
    from maniladder_ms.bench import bench, env_target, refuse_to_replace, save_rows

    if args.out:
        refuse_to_replace(args.out, args.update)  # before minutes of measuring, not after

    cat = _catalog()
    targets = []
    if args.tasks or not (args.robot or args.scene):
        specs = [cat.get(t) for t in args.tasks] if args.tasks else cat.filter(implemented=True)
        for spec in specs:
            if not spec.implemented:
                raise CatalogError(f"task {spec.id} is not implemented yet")
        targets += [env_target(s.env_id) for s in specs]
    targets += [env_target("ManiLadder-AgentGallery-v1", robot_uids=uid) for uid in _expand("robot", args.robot, _robots())]
    showcases = _showcases()
    targets += [env_target(showcases[k]) for k in _expand("scene", args.scene, sorted(showcases))]
    cameras = [c for c in (args.cameras or "").split(",") if c]
    rows = bench(targets, steps=args.steps, obs_mode=args.obs_mode, cameras=cameras or None,
                 render_every=args.render_every, progress=lambda e: print(f"  measuring {e} ...", file=sys.stderr))
    print_table(("env", "steps/s", "ratio to PickCube-v1", "PickCube-v1 beside it (steps/s)"),
                [(r["env_id"], f"{r['steps_per_s']:.0f}", f"{r['ratio']:.2f}", f"{r['reference_steps_per_s']:.0f}")
                 for r in rows])
    if args.out:
        table = save_rows(args.out, rows, args.steps, args.obs_mode, update=args.update)
        print(f"wrote {len(rows) - 1} rows to {args.out} ({len(table['rows'])} in all)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="maniladder", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)

    ls = sub.add_parser("list", help="the catalog as a table (* = implemented)")
    ls.add_argument("--level", type=int, choices=LEVELS)
    ls.add_argument("--suite", help="e.g. L1-rigid-SG")
    ls.add_argument("--embodiment", choices=EMBODIMENTS)
    ls.add_argument("--skill", choices=SKILLS)
    ls.add_argument("--object-class", choices=OBJECT_CLASSES)
    ls.add_argument("--implemented", action="store_true", help="only implemented tasks")
    ls.add_argument("--json", action="store_true", help="machine-readable output")
    ls.add_argument("--summary", action="store_true", help="implemented vs catalog counts per level and suite")
    ls.add_argument("--instructions", action="store_true",
                    help="each task's canonical language instruction (--json always has them, with the paraphrases)")
    ls.set_defaults(func=cmd_list)

    sh = sub.add_parser("show", help="a task's catalog row (family, params, rule, instructions), env class and solver, "
                                     "with their files")
    sh.add_argument("task")
    sh.set_defaults(func=cmd_show)

    rd = sub.add_parser("render", help="one PNG of a task (or an agent, or a deformable showcase) from all its cameras")
    rd.add_argument("task", nargs="?", help="task id, e.g. PickPlacePen")
    rd.add_argument("--robot", help="show an agent instead (ml_panda, ml_panda_leap, ...), with hand close-ups")
    rd.add_argument("--scene", help="show a deformable showcase instead (rope, towel, shirt, bag, tent, clay, liquid, granular)")
    rd.add_argument("--seed", type=int, default=0)
    rd.add_argument("--out", type=Path, help="PNG path (default: <task>_seed<seed>.png)")
    rd.add_argument("--size", type=int, default=256, help="pixels per camera image")
    rd.add_argument("--domain-randomization", "--dr", action="store_true")
    rd.add_argument("--visual-seed", type=int, help="with --dr: the look's seed (textures, lighting, distractors); "
                    "the layout stays the --seed episode's (default: the look of --seed)")
    rd.add_argument("--solved", action="store_true",
                    help="the task at the end of its scripted solver's --seed episode (what a demo reaches), not at reset")
    rd.set_defaults(func=cmd_render)

    bn = sub.add_parser("bench", help="control steps/s of tasks as ratios to PickCube-v1 (same process)")
    bn.add_argument("tasks", nargs="*", help="task ids (default: all implemented, unless --robot / --scene)")
    bn.add_argument("--robot", action="append", default=[], help="an agent's empty-scene rate (repeatable; 'all')")
    bn.add_argument("--scene", action="append", default=[], help="a deformable showcase (repeatable; 'all')")
    bn.add_argument("--steps", type=int, default=300)
    bn.add_argument("--obs-mode", default="state", help="state (default), or rgb for visual rollouts")
    bn.add_argument("--cameras", help="with a visual obs mode: the cameras the tasks capture, comma-separated "
                                      "(e.g. front_camera,left_camera,top_camera: the reference policy's view)")
    bn.add_argument("--render-every", type=int, default=1,
                    help="render the cameras on every k-th step only (an action chunk of k run open loop)")
    bn.add_argument("--out", type=Path, help="also record the rows in this JSON table (the tests' CI sample reads "
                                             "docs/bench/state.json: each task's speed prices its expensive checks)")
    bn.add_argument("--update", action="store_true",
                    help="with --out on an existing table: replace the rows measured now, keep the others")
    bn.set_defaults(func=cmd_bench)

    add_demos_parser(sub)
    add_eval_parsers(sub)
    add_serve_parser(sub)
    add_calibrate_parser(sub)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (UnknownTaskError, CatalogError, DemoFileError, FileExistsError, ValueError, NotImplementedError,
            DistributedError) as e:
        print(f"maniladder: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
