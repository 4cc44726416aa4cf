"""Episodes per minute of `maniladder eval` with `--workers K` against `--ray` on a local K-CPU Ray cluster: the
overhead of Ray at equal cores, on the same seeds, and whether both runs end in the same states.

    python scripts/bench_distributed.py                       # --policy solver --level 1 --episodes 1, K = 2
    python scripts/bench_distributed.py --tasks PickPlacePen,HangMug --episodes 3 --cpus 2 --json bench.json

Both runs call `evaluate`, the function `maniladder eval` calls, into fresh folders, one after the other
(`--ray-first` swaps them); the Ray instance runs only during its own run, and its start-up is timed apart and
not counted. The machine's load average is printed before and after:
on a shared machine the figure is only as good as the load it was measured under.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--policy", default="solver")
    sel = p.add_mutually_exclusive_group()
    sel.add_argument("--level", type=int, default=None)
    sel.add_argument("--tasks", help="comma-separated task ids (default: --level 1)")
    p.add_argument("--episodes", type=int, default=1, help="episodes per task (default 1)")
    p.add_argument("--cpus", type=int, default=2, help="worker processes and Ray CPUs (default 2)")
    p.add_argument("--out", type=Path, help="folder for both runs' results (default: a temporary folder)")
    p.add_argument("--json", type=Path, help="write the figures here")
    p.add_argument("--ray-first", action="store_true", help="run the Ray run first (default: the process pool first)")
    args = p.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    import ray

    from maniladder_ms.distributed import local_runtime_env
    from maniladder_ms.evaluation.results import read_episodes
    from maniladder_ms.evaluation.runner import evaluate

    tasks = [t for t in args.tasks.split(",") if t] if args.tasks else None
    level = None if tasks else (args.level or 1)
    out = args.out or Path(tempfile.mkdtemp(prefix="bench-distributed-"))
    for name in ("workers", "ray"):
        if (out / name).exists():
            raise SystemExit(f"{out / name} exists: give a fresh --out")
    load_before = os.getloadavg()
    common = dict(tasks=tasks, level=level, episodes=args.episodes, bootstrap=0)
    walls, ray_start = {}, None

    def run_workers():
        t0 = time.perf_counter()
        evaluate(args.policy, out / "workers", workers=args.cpus, **common)
        walls["workers"] = time.perf_counter() - t0

    def run_ray():
        nonlocal ray_start
        t0 = time.perf_counter()  # Ray runs only while its run does, so that its daemons do not slow the other one
        ray.init(num_cpus=args.cpus, include_dashboard=False, runtime_env=local_runtime_env())
        ray_start = time.perf_counter() - t0
        t0 = time.perf_counter()
        evaluate(args.policy, out / "ray", ray_address="auto", **common)
        walls["ray"] = time.perf_counter() - t0
        ray.shutdown()

    for run in (run_ray, run_workers) if args.ray_first else (run_workers, run_ray):
        run()
    load_after = os.getloadavg()

    outcomes = {k: {(r["task"], r["episode"]): (r["success"], r["state_digest"]) for r in read_episodes(out / k)}
                for k in walls}
    episodes = len(outcomes["workers"])
    differ = sorted(k for k in outcomes["workers"] if outcomes["workers"][k] != outcomes["ray"].get(k))
    figures = {
        "policy": args.policy, "selection": ",".join(tasks) if tasks else f"level {level}", "episodes": episodes,
        "cpus": args.cpus, "ray_start_s": round(ray_start, 1),
        "wall_s": {k: round(v, 1) for k, v in walls.items()},
        "episodes_per_min": {k: round(60 * episodes / v, 2) for k, v in walls.items()},
        "ray_over_workers": round(walls["ray"] / walls["workers"], 3), "order": list(walls),
        # the episodes' own time (reset to end, env creation and process start-up not included), summed
        "episode_s_sum": {k: round(sum(r["wall_s"] for r in read_episodes(out / k)), 1) for k in walls},
        "successes": {k: sum(s for s, _ in v.values()) for k, v in outcomes.items()},
        "episodes_that_differ": [list(k) for k in differ],
        "load_average_before": [round(x, 2) for x in load_before], "load_average_after": [round(x, 2) for x in load_after],
        "cores": os.cpu_count(), "results": str(out),
    }
    print(json.dumps(figures, indent=1))
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1))
    return 1 if differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
