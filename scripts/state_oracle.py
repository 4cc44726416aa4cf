"""The reference policy's state oracle: the same LadderFlow network and training as `maniladder calibrate`, fed
the task's privileged state (obs_mode "state": robot joints and velocities plus object poses) instead of image
features. It separates "the policy cannot see well enough" from "20 demos and this network cannot do the task
even with perfect perception".

It reads a calibration work folder (`maniladder calibrate --work W` made `W/<task>/features.npz` and the demos):
the demos' joint-target actions are replayed from each episode's reset in a state-obs env, the states before the
frames the visual policy trained on are its inputs (normalised per dimension), and the trained policy is
evaluated on the protocol's selection seeds (1,010,000 + k) with the catalog horizon.

    python scripts/state_oracle.py PickPlacePen --work runs/calibration_v3 --episodes 20
    python scripts/state_oracle.py PickPlacePen --work runs/calibration_v3 --noise 0   # deterministic sampling

`--demo-file` trains on another demo file's first `--num-demos` episodes instead (any recorded control mode,
converted to joint targets as the calibration does; e.g. `maniladder demos generate PickPlacePen --num 80 --out
/tmp/d80`): is 20 demos the limit?

    python scripts/state_oracle.py PickPlacePen --demo-file /tmp/d80/PickPlacePen/trajectory.none.pd_joint_pos.physx_cpu.h5 --num-demos 80 --steps 6000

Measured (session 14, protocol v3 settings, 3000 steps): see the issue-20 note.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

SELECTION_SEED_BASE = 1_010_000  # `maniladder eval --seed 1`: the protocol's selection seeds


def replay_states(env, ep, actions, frames):
    """Replay one demo's joint-target actions from its reset: (the states before `frames`, (F, 1, D), whether it
    succeeded at some step)."""
    from maniladder_ms.demos.files import episode_reset_kwargs

    obs, _ = env.reset(**episode_reset_kwargs(ep))
    states, success = [obs[0].float()], False
    for a in actions:
        obs, _, _, _, info = env.step(a[None])
        states.append(obs[0].float())
        success |= bool(info["success"][0])
    return torch.stack(states)[frames][:, None], success


def state_episodes(env, features, meta, n):
    """(normalised-later states (F, 1, D), joint-target actions (T, A), frames (F,)) per demo, and the
    replay success count."""
    episodes, replayed = [], 0
    for i, ep in enumerate(meta["episodes"][:n]):
        actions = torch.from_numpy(features[f"actions_{i}"]).float()
        frames = torch.from_numpy(features[f"frames_{i}"].astype(np.int64))
        states, success = replay_states(env, ep, actions, frames)
        replayed += success
        episodes.append((states, actions, frames))
    return episodes, replayed


def file_episodes(env, h5_path, meta, n, stride=2):
    """As `state_episodes`, from the first n episodes of a demo file (`meta`: its json): actions converted to joint
    targets as the calibration converts them (`demos.joint_targets`; a pd_joint_pos file passes through), frames
    every `stride` steps (as the calibration renders them)."""
    from maniladder_ms.demos.joint_targets import joint_target_episodes

    if len(meta["episodes"]) < n:
        sys.exit(f"{h5_path}: {len(meta['episodes'])} episodes, fewer than --num-demos {n}")
    episodes, replayed = [], 0
    for k, (actions, converted_ok, ep) in enumerate(joint_target_episodes(h5_path)):
        if k == n:
            break
        if not converted_ok:
            continue  # the recorded episode no longer succeeds when replayed: not a demo
        actions = torch.as_tensor(np.asarray(actions)).float()
        frames = torch.arange(0, len(actions), stride)
        states, success = replay_states(env, ep, actions, frames)
        replayed += success
        episodes.append((states, actions, frames))
    return episodes, replayed


class StateOraclePolicy:
    """A trained state oracle as a `maniladder eval` policy (obs mode "state", joint targets): the same episodes,
    seeds and success rule as the visual policy's evaluation."""

    obs_mode = "state"

    def __init__(self, task: str, policy, mean: torch.Tensor, std: torch.Tensor, noise: float = 1.0):
        from maniladder_ms.policy.calibrate import POLICY_CONTROL_MODE

        self.task, self.policy, self.mean, self.std, self.noise = task, policy, mean, std, noise
        self.control_mode = POLICY_CONTROL_MODE
        self.generator = torch.Generator()

    def supports(self, spec):
        return True if spec.id == self.task else f"oracle trained on {self.task}"

    def reset(self, ctx):
        self.generator.manual_seed(int(ctx.seed))

    def __call__(self, obs, spec):
        state = ((torch.as_tensor(obs)[0].float() - self.mean) / self.std).reshape(1, -1)  # one observation token
        return self.policy.act(state, generator=self.generator, noise=self.noise).numpy()


def oracle_env(task: str, meta: dict):
    """A state-obs env of `task` acting in joint targets, with the demo file's (`meta`) other env kwargs."""
    import maniladder_ms
    from maniladder_ms.demos.files import replay_env_kwargs
    from maniladder_ms.policy.calibrate import POLICY_CONTROL_MODE

    return maniladder_ms.make(task, obs_mode="state", control_mode=POLICY_CONTROL_MODE, **{
        k: v for k, v in replay_env_kwargs(meta).items() if k != "control_mode"})


def fit_oracle(task: str, episodes: list, steps: int, noise: float = 1.0, progress=False):
    """Train the LadderFlow network on (states, actions, frames) episodes, states normalised per dimension:
    (StateOraclePolicy, trainer, losses)."""
    from maniladder_ms.policy.flow import LadderFlowConfig, LadderFlowTrainer

    states = torch.cat([e[0] for e in episodes])
    mean, std = states.mean(0), states.std(0).clamp(min=1e-2)  # near-constant dims are not blown up
    episodes = [((s - mean) / std, a, f) for s, a, f in episodes]
    trainer = LadderFlowTrainer(LadderFlowConfig(keypoints=0, grid=1, train_steps=steps, augment_copies=0), episodes)
    losses = trainer.train(steps, progress=progress)
    return StateOraclePolicy(task, trainer.policy(), mean, std, noise), trainer, losses


def train_oracle(task: str, features_path: Path, demo_h5: Path, steps: int, num_demos: int = 20, progress=False):
    """Train the state oracle on a calibration's demos (the frames its features hold): (StateOraclePolicy, demos
    that replay to success from their joint targets, episodes trained on)."""
    from maniladder_ms.demos.files import load_demo_json

    features, meta = np.load(features_path), load_demo_json(Path(demo_h5))
    env = oracle_env(task, meta)
    try:
        episodes, replayed = state_episodes(env, features, meta, num_demos)
    finally:
        env.close()
    policy, _, _ = fit_oracle(task, episodes, steps, progress=progress)
    return policy, replayed, len(episodes)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("task")
    ap.add_argument("--work", default="runs/calibration_v3", help="calibration work folder holding <task>/features.npz")
    ap.add_argument("--steps", type=int, default=3000, help="training steps")
    ap.add_argument("--episodes", type=int, default=20, help="evaluation episodes on the selection seeds")
    ap.add_argument("--noise", type=float, default=1.0, help="scale of the flow's initial noise at inference")
    ap.add_argument("--out", default=None, help="save the trained checkpoint here")
    ap.add_argument("--demo-file", default=None, help="train on this demo file instead of the work folder's")
    ap.add_argument("--num-demos", type=int, default=None, help="with --demo-file: its first N episodes (default 20)")
    args = ap.parse_args(argv)

    import types

    import maniladder_ms
    from maniladder_ms.demos.files import demo_path, load_demo_json
    from maniladder_ms.policy.calibrate import CalibrationProtocol, demo_control_mode_for
    from tqdm import tqdm

    torch.set_num_threads(1)
    if args.num_demos is not None and not args.demo_file:
        sys.exit("--num-demos needs --demo-file (the work folder holds the protocol's 20 demos)")
    if args.demo_file:
        if not Path(args.demo_file).is_file():
            sys.exit(f"{args.demo_file} not found")
        meta = load_demo_json(Path(args.demo_file))
    else:
        work = Path(args.work) / args.task
        if not (work / "features.npz").is_file():
            sys.exit(f"{work}/features.npz not found: run `maniladder calibrate --tasks {args.task} --work {args.work}` first")
        features = np.load(work / "features.npz")
        meta = load_demo_json(demo_path(work / "demos", args.task, "none", demo_control_mode_for(args.task)))
    env = oracle_env(args.task, meta)
    if args.demo_file:
        episodes, replayed = file_episodes(env, args.demo_file, meta, args.num_demos or CalibrationProtocol().demos)
    else:
        episodes, replayed = state_episodes(env, features, meta, CalibrationProtocol().demos)
    print(f"{args.task}: {replayed}/{len(episodes)} demos replay to success from their joint targets")
    oracle, trainer, losses = fit_oracle(args.task, episodes, args.steps, noise=args.noise, progress=True)
    print(f"loss: first 50 steps {np.mean(losses[:50]):.3f}, last 200 {np.mean(losses[-200:]):.3f}")
    if args.out:
        trainer.save(args.out, meta={"task": args.task, "state_mean": oracle.mean, "state_std": oracle.std})
    spec = maniladder_ms.default_catalog().get(args.task)
    successes = []
    for k in tqdm(range(args.episodes), desc="evaluate"):
        seed = SELECTION_SEED_BASE + k
        obs, _ = env.reset(seed=seed)
        oracle.reset(types.SimpleNamespace(seed=seed))
        steps, done = 0, False
        while steps < spec.horizon and not done:
            for a in oracle(obs, spec):
                obs, _, _, _, info = env.step(np.asarray(a)[None])
                steps += 1
                done = bool(info["success"][0])
                if done or steps >= spec.horizon:
                    break
        successes.append(done)
    print(f"STATE ORACLE {args.task}: {sum(successes)}/{len(successes)} on selection seeds "
          f"(noise {args.noise}, {args.steps} steps, {len(episodes)} demos)")

if __name__ == "__main__":
    main()
