"""Control steps/s of each deformable showcase (random Panda actions, state obs) beside PickCube-v1.

    .venv/bin/python scripts/bench_deformables.py [KIND ...] [--steps 300]

Prints one row per showcase with its ratio to ManiSkill's PickCube-v1 measured in the same process
(before and after, averaged; see maniladder_ms.bench). The budget is >= 0.15x.
"""

import argparse

import maniladder_ms  # noqa: F401
from maniladder_ms.bench import bench
from maniladder_ms.deformables.showcase import SHOWCASE_ENV_IDS


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kinds", nargs="*", help=f"showcases to time (default: all of {', '.join(sorted(SHOWCASE_ENV_IDS))})")
    parser.add_argument("--steps", type=int, default=300)
    args = parser.parse_args()
    unknown = set(args.kinds) - set(SHOWCASE_ENV_IDS)
    if unknown:
        parser.error(f"unknown showcase(s): {', '.join(sorted(unknown))}")
    rows = bench([SHOWCASE_ENV_IDS[k] for k in args.kinds or sorted(SHOWCASE_ENV_IDS)], steps=args.steps)
    print(f"{'env':<34} {'steps/s':>8} {'x PickCube':>10}")
    for row in rows:
        print(f"{row['env_id']:<34} {row['steps_per_s']:>8.1f} {row['ratio']:>10.2f}")


if __name__ == "__main__":
    main()
