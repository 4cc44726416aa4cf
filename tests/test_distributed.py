"""`--ray`: evaluation and demo generation on a local Ray cluster give the local run's results (digest for digest,
action for action), resume from what the driver wrote, retry a lost worker, and name the task and seed of a
failure; without the extra, a clear error."""

import json
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from maniladder_ms.distributed import INSTALL_HINT, DistributedError, UnitFailed
from maniladder_ms.evaluation import eval_seed
from maniladder_ms.evaluation.results import read_episodes
from maniladder_ms.evaluation.runner import evaluate

REPO = Path(__file__).resolve().parents[1]
# one pytest worker runs this module (scripts/test.sh runs two): one local cluster, not one per worker
pytestmark = pytest.mark.xdist_group("ray")
TASKS = ["PickPlacePen", "LiftWideBox"]  # a single Panda and two: quick to build and to step

# 20 random actions seeded by the episode seed (state obs: nothing rendered); with `FAIL_SEED` it raises on that
# seed, with `CRASH_ONCE` (a file) the first worker to reach that seed dies, as a killed process would
POLICY = """
import os
import numpy as np
FAIL_SEED = {fail_seed}
CRASH_ONCE = {crash_once!r}
class OpenLoop:
    obs_mode = 'state'
    def run_episode(self, env, ctx):
        env.reset(seed=ctx.seed)
        if ctx.seed == FAIL_SEED:
            raise RuntimeError('a policy bug')
        if CRASH_ONCE and ctx.seed == FAIL_SEED + 1 and not os.path.exists(CRASH_ONCE):
            open(CRASH_ONCE, 'w').close()
            os._exit(1)
        rng = np.random.default_rng(ctx.seed)
        for _ in range(20):
            env.step(rng.uniform(ctx.action_space.low, ctx.action_space.high).astype(np.float32))
"""


def _policy(tmp_path, name="open_loop.py", fail_seed=-1, crash_once=""):
    f = tmp_path / name
    f.write_text(POLICY.format(fail_seed=fail_seed, crash_once=crash_once))
    return f"{f}:OpenLoop"


def _outcomes(folder):
    return {(r["task"], r["episode"]): (r["success"], r["state_digest"]) for r in read_episodes(folder)}


@pytest.fixture(scope="module")
def ray_cluster():
    """One local 2-CPU cluster for the module (~10 s); the commands find it initialised and use it."""
    ray = pytest.importorskip("ray")
    from maniladder_ms.distributed import local_runtime_env

    ray.init(num_cpus=2, include_dashboard=False, runtime_env=local_runtime_env())
    yield ray
    ray.shutdown()


def test_eval_on_ray_matches_the_local_run_retries_a_lost_worker_and_resumes(tmp_path, ray_cluster, monkeypatch):
    evaluate(_policy(tmp_path), tmp_path / "local", tasks=TASKS, episodes=2, progress=False, bootstrap=0)
    local = _outcomes(tmp_path / "local")
    assert len(local) == 4 and len({d for _, d in local.values()}) == 4  # four different end states to compare

    # one episode per task, the worker of PickPlacePen's dying once (Ray runs it again), then the same command
    # with two episodes: only the missing ones run
    crash = tmp_path / "crashed_once"
    _policy(tmp_path, name="crashing.py", fail_seed=eval_seed(0, 0) - 1, crash_once=str(crash))
    monkeypatch.chdir(tmp_path)
    pol = "crashing.py:OpenLoop"  # a policy file named relative to the driver's folder, which the workers lack
    evaluate(pol, tmp_path / "ray", tasks=TASKS, episodes=1, progress=False, bootstrap=0, ray_address="auto")
    assert crash.exists()  # a worker did die
    first = (tmp_path / "ray" / "episodes.jsonl").read_text()
    assert len(first.splitlines()) == 2
    summary = evaluate(pol, tmp_path / "ray", tasks=TASKS, episodes=2, progress=False, bootstrap=0,
                       ray_address="auto")
    lines = (tmp_path / "ray" / "episodes.jsonl").read_text()
    assert lines.startswith(first) and len(lines.splitlines()) == 4
    assert _outcomes(tmp_path / "ray") == local
    assert all(t["episodes"] == 2 for t in summary["tasks"].values())


def test_a_failing_episode_is_reported_with_its_task_and_seed(tmp_path, ray_cluster):
    bad = eval_seed(0, 1)
    with pytest.raises(UnitFailed) as e:
        evaluate(_policy(tmp_path, fail_seed=bad), tmp_path / "out", tasks=["PickPlacePen"], episodes=2,
                 progress=False, bootstrap=0, ray_address="auto")
    assert f"task PickPlacePen, episode 1 (seed {bad})" in str(e.value) and "a policy bug" in str(e.value)
    assert ("PickPlacePen", 1) not in _outcomes(tmp_path / "out")  # nothing recorded for it


def _demo_file(folder):
    (path,) = sorted(Path(folder).glob("PickPlacePen/*.h5"))
    with h5py.File(path, "r") as f:
        actions = {k: f[k]["actions"][()] for k in sorted(f)}
    meta = json.loads(path.with_suffix(".json").read_text())
    return actions, [(e["episode_seed"], e["instruction"]) for e in meta["episodes"]]


def test_demo_generation_on_ray_matches_the_local_run(tmp_path, ray_cluster):
    from maniladder_ms.demos.recording import generate

    for where, address in (("local", None), ("ray", "auto")):
        r = generate("PickPlacePen", 2, tmp_path / where, max_attempts=2, progress=False, ray_address=address)
        assert r.kept == 2
    local_actions, local_eps = _demo_file(tmp_path / "local")
    ray_actions, ray_eps = _demo_file(tmp_path / "ray")
    assert local_eps == ray_eps and [s for s, _ in ray_eps] == [0, 1]
    assert local_actions.keys() == ray_actions.keys() and len(ray_actions) == 2
    for k in local_actions:
        np.testing.assert_array_equal(local_actions[k], ray_actions[k])
    assert not (tmp_path / "ray" / "PickPlacePen" / ".parts").exists()


def test_without_ray_installed_the_error_names_the_extra(tmp_path, monkeypatch, capsys):
    from maniladder_ms.cli import main

    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    with pytest.raises(DistributedError, match=rf"install the extra: {INSTALL_HINT}".replace("[", r"\[").replace("]", r"\]")):
        evaluate("random", tmp_path / "eval", tasks=["PickPlacePen"], episodes=1, progress=False, ray_address="local")
    assert not (tmp_path / "eval").exists()  # refused before anything is written
    out = tmp_path / "demos"
    assert main(["demos", "generate", "PickPlacePen", "--num", "1", "--out", str(out), "--ray", "auto"]) == 2
    assert INSTALL_HINT in capsys.readouterr().err and not out.exists()
    assert main(["eval", "--policy", "random", "--tasks", "PickPlacePen", "--out", str(tmp_path / "e2"), "--ray"]) == 2
    assert INSTALL_HINT in capsys.readouterr().err


def test_ray_is_imported_only_in_the_distributed_module_and_only_inside_functions():
    import ast

    def imports_ray(node):
        return (isinstance(node, ast.Import) and any(a.name.split(".")[0] == "ray" for a in node.names)) or \
            (isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "ray")

    where = {}
    for f in sorted((REPO / "maniladder_ms").rglob("*.py")):
        tree = ast.parse(f.read_text())
        top = {id(n) for n in tree.body}
        for node in ast.walk(tree):
            if imports_ray(node):
                where.setdefault(f.relative_to(REPO).as_posix(), []).append("module level" if id(node) in top else "function")
    assert where == {"maniladder_ms/distributed.py": ["function"]}


@pytest.mark.slow
def test_calibration_on_ray_matches_the_local_run(tmp_path, ray_cluster):
    """Both training seeds of a tiny calibration (committed demos, 6 training steps, 1 episode a seed) on the
    cluster end in the local run's weights and result (~5 min here: the episodes render three cameras)."""
    import dataclasses

    import torch

    from maniladder_ms.policy.calibrate import calibrate
    from test_calibrate import TINY, TINY_PROTOCOL

    protocol = dataclasses.replace(TINY_PROTOCOL, checkpoints=1)
    for where, address in (("local", None), ("ray", "auto")):
        calibrate(["PickPlacePen"], tmp_path / where / "work", tmp_path / where / "out", demos_dir=REPO / "demos",
                  config=TINY, protocol=protocol, progress=False, ray_address=address)
    volatile = ("time", "timings_s", "cpu_s", "environment")
    local, ray = (json.loads((tmp_path / w / "out" / "PickPlacePen.json").read_text()) for w in ("local", "ray"))
    assert {k: v for k, v in ray.items() if k not in volatile} == {k: v for k, v in local.items() if k not in volatile}
    checkpoints = sorted((tmp_path / "local" / "work").rglob("checkpoint_*.pt"))
    assert len(checkpoints) == 2  # one per training seed
    for path in checkpoints:
        a = torch.load(path, weights_only=False)
        b = torch.load(tmp_path / "ray" / "work" / path.relative_to(tmp_path / "local" / "work"), weights_only=False)
        for part in ("net", "ema"):
            assert a[part].keys() == b[part].keys()
            assert all(torch.equal(a[part][k], b[part][k]) for k in a[part])
    assert not list((tmp_path / "ray" / "work").glob(".cluster-probe-*"))  # the run's probe file is gone


def test_a_worker_with_other_sources_or_without_the_work_folder_refuses_to_run(tmp_path):
    """What a unit checks on its worker before it runs (called here in-process, as a Ray worker would)."""
    import torch

    from maniladder_ms.distributed import run_unit, source_digest
    from maniladder_ms.policy.calibrate import _check_work_visible

    threads = torch.get_num_threads()
    try:
        assert run_unit(sorted, ([2, 1],), {}, source_digest()) == [1, 2]
        assert torch.get_num_threads() == 1  # one torch thread per unit
    finally:
        torch.set_num_threads(threads)
    with pytest.raises(DistributedError, match="install the same commit on every node"):
        run_unit(sorted, ([2, 1],), {}, "0" * 16)
    with pytest.raises(DistributedError, match="a file system every node mounts at the same path"):
        _check_work_visible({"work": tmp_path / "elsewhere"}, "token")
