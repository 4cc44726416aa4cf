"""Round-trip cost per call of a policy served on the loopback (`maniladder serve`, `--policy openpi://...`)
against the same policy in process, on real observations of a task's cameras.

    python scripts/bench_remote_policy.py [--task PickPlacePen] [--cameras front_camera,left_camera,top_camera]
        [--calls 300] [--size 128]

The policy is `ZeroChunk` below (a chunk of zero actions: no compute), so the difference is the transport: wire
message, msgpack, websocket, the server's rebuild of the observation and its thread hop. Prints the median and p90
per call, and the machine's load average over the run (the figure depends on it).
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


class ZeroChunk:
    """A chunk of 8 zero actions per call (the Panda's 8-D `pd_joint_delta_pos`)."""

    def __call__(self, obs, spec):
        return np.zeros((8, 8), dtype=np.float32)


def start_server(policy: str, log: Path) -> tuple[subprocess.Popen, int]:
    cmd = [sys.executable, "-m", "maniladder_ms.cli", "serve", "--policy", policy, "--port", "0"]
    with open(log, "w") as f:
        proc = subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, start_new_session=True)
    deadline = time.time() + 300
    while time.time() < deadline:
        m = re.search(r"on ws://127\.0\.0\.1:(\d+)", log.read_text())
        if m:
            return proc, int(m.group(1))
        if proc.poll() is not None:
            break
        time.sleep(0.3)
    raise SystemExit(f"the server did not start:\n{log.read_text()}")


def timed(fn, calls: int) -> np.ndarray:
    out = np.empty(calls)
    for i in range(calls):
        t0 = time.perf_counter()
        fn()
        out[i] = time.perf_counter() - t0
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--task", default="PickPlacePen")
    ap.add_argument("--cameras", default="front_camera,left_camera,top_camera")
    ap.add_argument("--calls", type=int, default=300)
    ap.add_argument("--size", type=int, default=128, help="camera image side in pixels")
    args = ap.parse_args()

    import maniladder_ms
    from maniladder_ms.evaluation import eval_seed
    from maniladder_ms.evaluation.policies import EpisodeContext, load_policy
    from maniladder_ms.evaluation.runner import filter_obs

    spec = maniladder_ms.default_catalog().get(args.task)
    cameras = tuple(args.cameras.split(","))
    env = maniladder_ms.make(spec.id, obs_mode="rgb", cameras=cameras,
                             sensor_configs=dict(width=args.size, height=args.size))
    obs, _ = env.reset(seed=eval_seed(0, 0))
    obs = filter_obs(obs, "rgb")
    base = env.unwrapped
    ctx = EpisodeContext(spec=spec, seed=eval_seed(0, 0), episode=0, action_space=base.single_action_space,
                         obs_mode="rgb", control_mode=base.control_mode, horizon=spec.horizon,
                         instruction=spec.instruction)
    image_bytes = sum(np.asarray(v["rgb"]).nbytes for v in obs["sensor_data"].values())

    policy_spec = f"{Path(__file__).resolve()}:ZeroChunk"
    local = load_policy(policy_spec)
    load0 = os.getloadavg()
    in_process = timed(lambda: local(obs, spec), args.calls)
    with tempfile.TemporaryDirectory() as tmp:
        proc, port = start_server(policy_spec, Path(tmp) / "server.log")
        try:
            remote = load_policy(f"openpi://127.0.0.1:{port}")
            remote.reset(ctx)
            for _ in range(10):  # warm-up: the server's first calls import and build its episode context
                remote(obs, spec)
            over_wire = timed(lambda: remote(obs, spec), args.calls)
            remote.close()
        finally:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(timeout=30)
    load1 = os.getloadavg()
    env.close()

    def row(name, t):
        return f"{name:<12} median {1000 * np.median(t):8.3f} ms   p90 {1000 * np.percentile(t, 90):8.3f} ms"

    print(f"{args.calls} calls, {args.task}, {len(cameras)} cameras rgb {args.size}x{args.size} "
          f"({image_bytes / 1024:.0f} KiB of images per call); {os.cpu_count()} CPUs, load average (1 min) "
          f"{load0[0]:.1f} before, {load1[0]:.1f} after")
    print(row("in process", in_process))
    print(row("loopback", over_wire))
    print(f"round-trip overhead: median {1000 * (np.median(over_wire) - np.median(in_process)):.2f} ms per call")
    return 0


if __name__ == "__main__":
    sys.exit(main())
