"""Trace a trained LadderFlow policy's evaluation episodes step by step, to see where a calibration round fails.

    python scripts/trace_episodes.py TASK CHECKPOINT OUT [--episodes 12] [--object ATTR] [--seed 1]

Runs the protocol's evaluation (`maniladder_ms.evaluation.runner.evaluate`: the same episodes and seeds as a
development run with `--seed`) and logs after every control step: the task object's position (`--object`, an env
attribute, default `item`, else `cube`; an articulation's root link), every TCP's position, whether each end
effector holds and touches the object (`ee.holds`, `ee.touches`), the robot's joint positions, and the scalar
entries of the step's info (the rule's flags and measures). Writes OUT/trace.jsonl (one row a step) beside the
evaluation's own OUT/episodes.jsonl.
The checkpoint is a calibration work folder's `<task>/<hash>/seed_<k>/checkpoint_<steps>.pt`; trace it on the task
version it was trained on (its `task_hash`), or the episodes are not the ones the result counted.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("task")
    ap.add_argument("checkpoint", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--episodes", type=int, default=12)
    ap.add_argument("--object", default=None, help="the env attribute of the object to follow (default: item, cube)")
    ap.add_argument("--seed", type=int, default=1, help="the evaluation's seed set (development runs: 1)")
    args = ap.parse_args(argv)
    if not args.checkpoint.is_file():
        ap.error(f"{args.checkpoint}: no such checkpoint")
    if args.episodes < 1:
        ap.error("--episodes must be at least 1")
    if (args.out / "trace.jsonl").exists():
        ap.error(f"{args.out / 'trace.jsonl'} exists: choose another OUT (nothing is overwritten)")

    torch.set_num_threads(1)
    from maniladder_ms.evaluation import runner
    from maniladder_ms.policy.evaluate import LadderFlowEvalPolicy

    rows = []
    step = runner.EpisodeMonitor.step

    def traced_step(monitor, action):
        out = step(monitor, action)
        base = monitor.env.unwrapped
        names = [args.object] if args.object else ["item", "cube"]
        obj = next((getattr(base, n) for n in names if hasattr(base, n)), None)
        if obj is None:
            raise SystemExit(f"{args.task} has no attribute {' or '.join(names)}: pass --object")
        if hasattr(obj, "root"):  # an articulation: its root link is what a hand holds and touches
            obj = obj.root
        ee = base.ee
        row = dict(seed=monitor.seed, t=monitor.steps, obj=obj.pose.p[0].tolist(),
                   qpos=base.agent.robot.get_qpos()[0].tolist(),
                   info={k: float(v.reshape(-1)[0]) for k, v in out[4].items()
                         if hasattr(v, "reshape") and v.numel() == 1})
        for side in ee.sides:
            row[f"{side}_tcp"] = ee.tcp(side).p[0].tolist()
            row[f"{side}_holds"] = bool(ee.holds(obj, side)[0])
            row[f"{side}_touches"] = bool(ee.touches(obj, side)[0])
        rows.append(row)
        return out

    runner.EpisodeMonitor.step = traced_step
    try:
        runner.evaluate(LadderFlowEvalPolicy(args.checkpoint), args.out, tasks=[args.task], episodes=args.episodes,
                        seed=args.seed, progress=True, bootstrap=0)
    finally:
        runner.EpisodeMonitor.step = step
    (args.out / "trace.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    print(f"{len(rows)} steps of {args.episodes} episodes -> {args.out / 'trace.jsonl'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
