"""Remote policies (`--policy openpi://HOST:PORT`) against our own server (`maniladder serve`) on the loopback:
the same episodes as in process, digest for digest; a killed server, a timeout, a wrong action shape and a failing
server policy give clear errors naming task, seed and step; a resumed run completes."""

import dataclasses
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time

import pytest

import maniladder_ms
from maniladder_ms.evaluation import eval_seed
from maniladder_ms.evaluation.policies import PolicyError, load_policy, policy_identity, policy_label
from maniladder_ms.evaluation.remote import RemotePolicyError, parse_spec
from maniladder_ms.evaluation.results import read_episodes
from maniladder_ms.evaluation.runner import evaluate

TASKS = ["PickPlacePen", "LiftBottleHand"]  # two embodiments: an 8-D Panda, a LEAP hand's larger action
HORIZON = 12  # short episodes: three calls of 4-action chunks
CAMERAS = "front_camera"

# A deterministic visual policy: each chunk mixes the cameras' mean brightness into episode-seeded noise, so images
# that arrive wrong (or a reset that is missed) change the episode. Files in MISBEHAVE_DIR make it misbehave.
POLICY = '''
import json, os, time
import numpy as np

class Bright:
    image_size = 64

    def reset(self, ctx):
        self.rng = np.random.default_rng(ctx.seed)
        self.low, self.high = ctx.action_space.low, ctx.action_space.high
        self.episode, self.calls = ctx.episode, 0

    def _trouble(self, name):
        path = os.path.join(os.environ.get("MISBEHAVE_DIR", "/nonexistent"), name)
        return os.path.exists(path)

    def __call__(self, obs, spec):
        self.calls += 1
        cams = obs["sensor_data"]
        with open(__file__ + ".seen", "a") as f:
            f.write(json.dumps({c: list(np.asarray(v["rgb"]).shape) for c, v in cams.items()}) + "\\n")
        if self.episode == 1 and self.calls == 2 and self._trouble("die"):
            os.remove(os.path.join(os.environ["MISBEHAVE_DIR"], "die"))
            os._exit(1)  # the server process dies mid-episode
        if self._trouble("slow"):
            time.sleep(4)
        if self._trouble("shape"):
            return np.zeros((4, 3), dtype=np.float32)
        if self._trouble("raise"):
            raise RuntimeError("the model is not loaded")
        b = sum(float(np.asarray(cams[c]["rgb"], dtype=np.float64).mean()) for c in sorted(cams)) / 255.0
        a = self.rng.uniform(self.low, self.high, size=(4, len(self.low))) * 0.5 + (b - 0.5) * 0.2
        return np.clip(a, self.low, self.high).astype(np.float32)
'''


@pytest.fixture(scope="module")
def short_tasks():
    """The catalog with TASKS' horizons cut to HORIZON for this module (the served policy never reads it)."""
    cat = maniladder_ms.default_catalog()
    saved = {t: cat._by_id[t] for t in TASKS}
    for t in TASKS:
        cat._by_id[t] = dataclasses.replace(saved[t], horizon=HORIZON)
    yield
    cat._by_id.update(saved)


@pytest.fixture(scope="module")
def policy_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("remote")
    (d / "trouble").mkdir()
    path = d / "bright_policy.py"
    path.write_text(POLICY)
    return path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """`maniladder serve` in a subprocess on the loopback; `start` again after a stop keeps the address."""

    def __init__(self, policy: str, log, env=None):
        self.policy, self.log, self.env, self.port = policy, log, env, 0
        self.start()

    def start(self):
        cmd = [sys.executable, "-m", "maniladder_ms.cli", "serve", "--policy", self.policy, "--port", str(self.port)]
        with open(self.log, "w") as f:
            self.proc = subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, env={**os.environ, **(self.env or {})},
                                         start_new_session=True)
        deadline = time.time() + 180
        while time.time() < deadline:
            m = re.search(r"on ws://127\.0\.0\.1:(\d+)", self.log.read_text())
            if m:
                self.port = int(m.group(1))
                self.url = f"openpi://127.0.0.1:{self.port}"
                return
            if self.proc.poll() is not None:
                break
            time.sleep(0.3)
        self.stop()
        raise AssertionError(f"the server did not start: {self.log.read_text()[-2000:]}")

    def stop(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
        return self.proc.wait(timeout=30)


@pytest.fixture(scope="module")
def server(policy_file, tmp_path_factory):
    srv = Server(f"{policy_file}:Bright", tmp_path_factory.mktemp("log") / "server.log",
                 env={"MISBEHAVE_DIR": str(policy_file.parent / "trouble")})
    yield srv
    srv.stop()


def _outcomes(out):
    return {(r["task"], r["episode"]): (r["seed"], r["success"], r["steps"], r["state_digest"]) for r in read_episodes(out)}


def _seen(policy_file):
    path = policy_file.parent / (policy_file.name + ".seen")
    lines = path.read_text().splitlines() if path.exists() else []
    path.unlink(missing_ok=True)
    return [json.loads(x) for x in lines]


@pytest.fixture(scope="module")
def local_run(short_tasks, policy_file, tmp_path_factory):
    """The policy in process: the reference the remote runs must match."""
    out = tmp_path_factory.mktemp("local") / "run"
    evaluate(f"{policy_file}:Bright", out, tasks=TASKS, episodes=2, cameras=CAMERAS, progress=False)
    return {"out": out, "outcomes": _outcomes(out), "seen": _seen(policy_file)}


def test_remote_episodes_match_in_process(server, local_run, policy_file, tmp_path):
    out = tmp_path / "remote"
    evaluate(server.url, out, tasks=TASKS, episodes=2, cameras=CAMERAS, progress=False)
    remote = _outcomes(out)
    assert set(remote) == {(t, k) for t in TASKS for k in range(2)}
    assert remote == local_run["outcomes"]  # same seeds, steps, success and end states (state_digest)
    assert len({v[3] for v in remote.values()}) == 4  # the digests tell episodes apart (the check can fail)
    # the served policy saw what the in-process one saw: the front camera alone, at its declared 64 px
    seen = _seen(policy_file)
    assert seen == local_run["seen"] and len(seen) == 2 * 2 * (HORIZON // 4)
    assert all(s == {"front_camera": [1, 64, 64, 3]} for s in seen)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["policy"] == server.url and manifest["cameras"] == [CAMERAS]
    assert {r["instruction"] for r in read_episodes(out)} == {maniladder_ms.default_catalog().get(t).instruction for t in TASKS}


def test_killed_server_is_a_clear_error_and_the_run_resumes(server, local_run, policy_file, tmp_path):
    out, die = tmp_path / "run", policy_file.parent / "trouble" / "die"
    die.touch()  # the server dies at episode 1's second call (step 5)
    try:
        with pytest.raises(RemotePolicyError, match=rf"task {TASKS[0]}, step 5 \(seed {eval_seed(0, 1)}\): remote "
                                                    r"policy ws://127\.0\.0\.1:\d+: the connection dropped.*resume"):
            evaluate(server.url, out, tasks=TASKS[:1], episodes=2, cameras=CAMERAS, progress=False)
        assert server.stop() == 1  # it died (os._exit(1)), not stopped by us
        before = (out / "episodes.jsonl").read_text()
        assert [r["episode"] for r in read_episodes(out)] == [0]  # the finished episode is on disk
        with pytest.raises(RemotePolicyError, match=rf"no policy server at ws://127\.0\.0\.1:{server.port}"):
            evaluate(server.url, out, tasks=TASKS[:1], episodes=2, cameras=CAMERAS, progress=False)
    finally:
        die.unlink(missing_ok=True)
        if server.proc.poll() is not None:
            server.start()  # same address: the same run (the address is its policy)
        _seen(policy_file)
    # the resume may give the calls more time: the timeout is no part of the run's identity
    evaluate(server.url + "?timeout=30", out, tasks=TASKS[:1], episodes=2, cameras=CAMERAS, progress=False)
    assert json.loads((out / "manifest.json").read_text())["policy"] == server.url
    assert (out / "episodes.jsonl").read_text().startswith(before)
    local = {k: v for k, v in local_run["outcomes"].items() if k[0] == TASKS[0]}
    assert _outcomes(out) == local  # episode 1 re-ran from its seed and ended as in process


def _one_call(url, action_dim=8):
    """One remote call outside an env (episode 3 of PickPlacePen, a black front camera)."""
    import gymnasium as gym
    import numpy as np

    from maniladder_ms.evaluation.policies import EpisodeContext

    spec = maniladder_ms.default_catalog().get(TASKS[0])
    policy = load_policy(url)
    policy.reset(EpisodeContext(spec=spec, seed=eval_seed(0, 3), episode=3, horizon=HORIZON, obs_mode="rgb",
                                action_space=gym.spaces.Box(-1, 1, (action_dim,), np.float32),
                                control_mode="pd_joint_delta_pos", instruction=spec.instruction))
    try:
        return policy({"sensor_data": {"front_camera": {"rgb": np.zeros((1, 64, 64, 3), np.uint8)}}}, spec)
    finally:
        policy.close()


def test_timeout_wrong_shape_and_server_errors_are_clear(server, policy_file):
    trouble = policy_file.parent / "trouble"
    where = rf"task {TASKS[0]}, step 1 \(seed {eval_seed(0, 3)}\): remote policy ws://127\.0\.0\.1:{server.port}: "
    try:
        assert _one_call(server.url).shape == (4, 8)
        (trouble / "slow").touch()
        with pytest.raises(RemotePolicyError, match=where + r"no reply within 1 s \(timeout"):
            _one_call(server.url + "?timeout=1")
        (trouble / "slow").unlink()
        (trouble / "shape").touch()
        with pytest.raises(RemotePolicyError, match=where + r"the server returned actions of shape \(4, 3\); the env's "
                                                    r"action space in control mode pd_joint_delta_pos is 8-D.*control_mode"):
            _one_call(server.url)
        (trouble / "shape").unlink()
        (trouble / "raise").touch()  # the server's policy fails: its traceback comes back in the error
        with pytest.raises(RemotePolicyError, match=where + r"the server failed:\nTraceback(.|\n)*RuntimeError: the "
                                                    r"model is not loaded"):
            _one_call(server.url)
    finally:
        for name in ("slow", "shape", "raise"):
            (trouble / name).unlink(missing_ok=True)
        _seen(policy_file)


def test_spec_parsing_and_missing_pieces(monkeypatch):
    assert parse_spec("openpi://gpu-box:8000") == ("gpu-box", 8000, {}, 60.0)
    host, port, declared, timeout = parse_spec("openpi://10.0.0.2:9000?control_mode=pd_ee_delta_pose&state=1"
                                               "&cameras=front_camera,hand_camera&image_size=224&timeout=5")
    assert declared == {"control_mode": "pd_ee_delta_pose", "state": True, "image_size": 224,
                        "cameras": ("front_camera", "hand_camera")} and timeout == 5.0
    for bad, why in [("openpi://host", "HOST:PORT"), ("openpi://host:80?colour=red", "unknown option.*colour"),
                     ("openpi://host:80?state=maybe", "boolean"), ("openpi://host:80?timeout=0", "timeout")]:
        with pytest.raises(RemotePolicyError, match=why):
            load_policy(bad)
    with pytest.raises(RemotePolicyError, match=r"no policy server at ws://127\.0\.0\.1:\d+.*maniladder serve"):
        load_policy(f"openpi://127.0.0.1:{_free_port()}")
    assert policy_label("openpi://gpu-box:8000?state=1") == "openpi-gpu-box-8000"
    assert policy_identity("openpi://gpu-box:8000?timeout=5&state=1&cameras=front_camera,hand_camera") == \
        "openpi://gpu-box:8000?cameras=front_camera,hand_camera&state=1"
    assert policy_identity("openpi://gpu-box:8000?timeout=5") == "openpi://gpu-box:8000"
    monkeypatch.setitem(sys.modules, "openpi_client", None)  # the extra not installed
    with pytest.raises(PolicyError, match=r"pip install 'maniladder-ms\[remote\]'"):
        load_policy("openpi://127.0.0.1:8000")


def test_serve_refuses_what_the_wire_cannot_carry(capsys):
    from maniladder_ms.cli import main

    assert main(["serve", "--policy", "solver", "--port", "0"]) == 2
    assert "drives the env itself" in capsys.readouterr().err
