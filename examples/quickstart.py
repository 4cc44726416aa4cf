"""The main job in one script: make a ManiLadder env, run its scripted demo, evaluate success.

    .venv/bin/python examples/quickstart.py PickPlacePen --episodes 10 --video videos/
"""

import argparse
from pathlib import Path

import numpy as np
from mani_skill.utils.wrappers.record import RecordEpisode

import maniladder_ms
from maniladder_ms.solvers import solve, solver_for, sweep


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("task", nargs="?", default="PickPlacePen")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--video", metavar="DIR", help="also save an mp4 of the first demo episode here, as DIR/TASK_seedSEED.mp4")
    p.add_argument("--overwrite", action="store_true", help="replace that video if it exists")
    args = p.parse_args()

    spec = maniladder_ms.default_catalog().get(args.task)
    video = Path(args.video) / f"{spec.id}_seed{args.seed}.mp4" if args.video else None
    if video is not None and video.exists() and not args.overwrite:
        raise SystemExit(f"{video} exists; pass --overwrite to replace it")
    print(f"{spec.id}: level {spec.level}, suite {spec.suite}, skills {', '.join(spec.skills)}")
    print(f"  success rule (catalog intent): {spec.success}")

    # 1. a plain gymnasium env, as any ManiSkill task
    env = maniladder_ms.make(spec.id, obs_mode="state", reward_mode="normalized_dense")
    obs, _ = env.reset(seed=args.seed)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    print(f"  obs {tuple(obs.shape)}, action space {env.action_space.shape}, reward {float(reward[0]):.3f}")
    env.close()

    # 2. its scripted demonstration, evaluated over seeds
    rows = sweep(spec.id, range(args.seed, args.seed + args.episodes), progress=True)
    rate = np.mean([r["success"] for r in rows])
    steps = [r["steps"] for r in rows]
    print(f"  scripted solver: success {rate:.0%} over {len(rows)} seeds, "
          f"episode length mean {np.mean(steps):.0f} (max {max(steps)}, horizon {spec.horizon})")

    # 3. watch one, recorded in the control mode the solver drives (not every solver drives the same one)
    if args.video:
        env = maniladder_ms.make(spec.id, obs_mode="state", control_mode=solver_for(spec.id).control_mode,
                                 render_mode="rgb_array")
        env = RecordEpisode(env, output_dir=args.video, save_trajectory=False, save_on_reset=False, video_fps=20,
                            source_type="maniladder", source_desc="scripted solver")
        info = solve(env, args.seed)
        env.flush_video(name=video.stem)
        env.close()
        print(f"  video of seed {args.seed} (success {bool(info['success'][0])}) saved as {video}")


if __name__ == "__main__":
    main()
