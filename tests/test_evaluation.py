"""Evaluation protocol (`maniladder eval`) and ladder report (`maniladder report`)."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import maniladder_ms
from maniladder_ms.evaluation import EVAL_SEED_BASE, PROTOCOL_VERSION, eval_seed
from maniladder_ms.evaluation.cli import main as eval_main
from maniladder_ms.evaluation.policies import PolicyError, RandomPolicy, load_policy
from maniladder_ms.evaluation.results import ResultsError, load_results, read_episodes
from maniladder_ms.evaluation.runner import as_action_chunk, evaluate
from maniladder_ms.evaluation.stats import ladder_level, level_thresholds, summarize, wilson_interval

from conftest import FIXTURE_LEVEL, FIXTURE_TASK

PEN = "PickPlacePen"


def _records(task, successes, n):
    return [dict(task=task, episode=k, seed=eval_seed(0, k), success=k < successes, steps=10, wall_s=0.1)
            for k in range(n)]


# ---- statistics (no simulation) -----------------------------------------------------------------
def test_wilson_interval_known_values():
    lo, hi = wilson_interval(0, 20)
    assert lo == 0.0 and hi == pytest.approx(0.1611, abs=1e-3)
    lo, hi = wilson_interval(20, 20)
    assert lo == pytest.approx(0.8389, abs=1e-3) and hi == 1.0
    lo, hi = wilson_interval(10, 20)
    assert lo == pytest.approx(0.2993, abs=1e-3) and hi == pytest.approx(0.7007, abs=1e-3)


def test_thresholds_come_from_the_catalog_calibration():
    t = level_thresholds()
    assert (t[1]["value"], t[1]["strict"]) == (0.6, False)
    assert (t[2]["value"], t[2]["strict"]) == (0.2, False)
    assert (t[3]["value"], t[3]["strict"]) == (0.0, True)
    assert (t[4]["value"], t[4]["strict"]) == (0.0, True)


def test_ladder_level_rules():
    t = level_thresholds()
    assert ladder_level({1: 0.6, 2: 0.2, 3: 0.01, 4: 0.0}, t) == (3, True)  # 60% and 20% clear exactly
    assert ladder_level({1: 0.59, 2: 0.9, 3: 0.5, 4: 0.5}, t) == (0, True)  # no skipping a failed level
    assert ladder_level({1: 0.9, 2: 0.3, 3: 0.1, 4: 0.05}, t) == (4, True)
    assert ladder_level({1: 0.9, 2: None, 3: 0.5, 4: None}, t) == (1, False)  # climb stops at a missing level
    assert ladder_level({1: None, 2: 0.9, 3: None, 4: None}, t) == (0, False)


def test_summary_suites_levels_and_missing_tasks():
    recs = _records(PEN, 16, 20) + _records("Stack6Blocks", 6, 20)
    s = summarize(recs, bootstrap=500)
    assert s["tasks"][PEN]["rate"] == 0.8 and s["tasks"]["Stack6Blocks"]["rate"] == 0.3
    assert s["suites"]["L1-rigid-SG"]["mean"] == 0.8 and s["suites"]["L1-rigid-SG"]["n_tasks"] == 1
    assert s["suites"]["L1-rigid-SX"]["mean"] is None  # no task evaluated: missing, not 0
    assert s["levels"]["1"]["mean"] == 0.8 and s["levels"]["3"]["mean"] is None
    lad = s["ladder"]
    assert lad["level"] == 2 and lad["exact"] is False and ">= 2" in lad["text"]
    assert lad["ci"][0] <= 2 <= lad["ci"][1] and abs(sum(lad["probabilities"].values()) - 1) < 1e-9
    lo, hi = s["levels"]["1"]["ci"]
    assert lo < 0.8 < hi


def test_bootstrap_puts_a_marginal_level_in_doubt():
    s = summarize(_records(PEN, 12, 20), bootstrap=1000)  # 60%: clears L1 only just
    assert s["ladder"]["level"] == 1
    assert 0.3 < s["ladder"]["probabilities"]["1"] < 0.8 and s["ladder"]["ci"] == [0, 1]


def test_action_checks_name_task_and_step():
    assert as_action_chunk(np.zeros(8), 8, "x").shape == (1, 8)
    assert as_action_chunk(np.zeros((1, 8)), 8, "x").shape == (1, 8)
    assert as_action_chunk(np.zeros((5, 8)), 8, "x").shape == (5, 8)
    assert as_action_chunk([[[0.0] * 8] * 3], 8, "x").shape == (3, 8)
    with pytest.raises(PolicyError, match=r"task T, step 4.*shape \(7,\)"):
        as_action_chunk(np.zeros(7), 8, "task T, step 4")
    with pytest.raises(PolicyError, match="non-finite"):
        as_action_chunk(np.array([0, 0, np.nan, 0, 0, 0, 0, 0]), 8, "task T, step 4")


def test_seed_scheme_is_disjoint_from_demo_seeds():
    assert eval_seed(0, 0) == EVAL_SEED_BASE == 1_000_000
    assert eval_seed(1, 5) == 1_010_005
    with pytest.raises(ValueError):
        eval_seed(0, 10_000)


def test_policy_loading_errors(tmp_path):
    with pytest.raises(PolicyError, match="unknown policy"):
        load_policy("nonsense")
    with pytest.raises(PolicyError, match="cannot import"):
        load_policy("no_such_module_xyz:policy")
    with pytest.raises(PolicyError, match="not found"):
        load_policy(str(tmp_path / "missing.py") + ":policy")
    with pytest.raises(PolicyError, match="does not exist"):
        load_policy("replay:" + str(tmp_path / "none.h5"))
    f = tmp_path / "pol.py"
    f.write_text("def policy(obs, spec):\n    return [0.0] * 8\n")
    assert load_policy(f"{f}:policy").name == f"{f}:policy"
    with pytest.raises(PolicyError, match="no attribute"):
        load_policy(f"{f}:other")


# ---- evaluation runs (simulation) ---------------------------------------------------------------
def test_solver_policy_succeeds_on_pickplacepen(tmp_path):
    s = evaluate("solver", tmp_path / "solver", tasks=[PEN], episodes=6, progress=False)
    t = s["tasks"][PEN]
    # the solver succeeds on 49 of the first 50 evaluation seeds (seed 1000000 fails)
    assert t["episodes"] == 6 and t["successes"] >= 5, t
    recs = read_episodes(tmp_path / "solver")
    assert [r["seed"] for r in recs] == [eval_seed(0, k) for k in range(6)]
    assert all(r["control_mode"] == "pd_joint_pos" and 0 < r["steps"] <= 150 for r in recs)
    # how far each episode got: a success grasped the pen and held it over the tray on the way
    assert all({"is_grasped", "is_over_tray"} <= set(r["reached"]) for r in recs if r["success"]), recs
    assert t["reached"]["is_grasped"] >= 5 / 6 and "success" not in t["reached"], t
    assert s["ladder"]["level"] == 1 and not s["ladder"]["exact"]
    assert (tmp_path / "solver" / "summary.json").exists()


def test_episode_records_show_how_far_each_measure_got(tmp_path):
    """Beside the flags reached, each record holds the least, greatest and last value of the task's continuous
    measures (LiftWideBox: the box's height and tilt): the solver lifts the box past the rule's height, random
    actions do not."""
    task = "LiftWideBox"
    lift = maniladder_ms.default_catalog().get(task).params["lift_height"]
    evaluate("solver", tmp_path / "solver", tasks=[task], episodes=1, progress=False)
    evaluate("random", tmp_path / "random", tasks=[task], episodes=1, progress=False)
    (solved,), (random,) = read_episodes(tmp_path / "solver"), read_episodes(tmp_path / "random")
    assert solved["success"] and solved["measures"]["height"]["max"] >= lift > solved["measures"]["height"]["min"]
    assert {"min", "max", "last"} == set(solved["measures"]["tilt"]) and solved["measures"]["tilt"]["last"] < 0.26
    assert not random["success"] and random["measures"]["height"]["max"] < lift


def test_random_policy_gets_nothing(tmp_path):
    s = evaluate("random", tmp_path / "random", tasks=[PEN], episodes=3, progress=False)
    t = s["tasks"][PEN]
    assert t["successes"] == 0 and t["mean_steps"] == 150  # ran to the horizon every time
    assert not any("is_grasped" in r["reached"] for r in read_episodes(tmp_path / "random"))
    pen = maniladder_ms.default_catalog().get(PEN)
    assert {r["instruction"] for r in read_episodes(tmp_path / "random")} == {pen.instruction}  # canonical by default
    assert s["ladder"]["level"] == 0 and s["ladder"]["exact"]


class KilledRandom(RandomPolicy):
    """Random policy whose process 'dies' (KeyboardInterrupt) when episode `kill_at` starts."""

    name = "killed-random"

    def __init__(self, kill_at=None):
        super().__init__()
        self.kill_at = kill_at

    def reset(self, ctx):
        if ctx.episode == self.kill_at:
            raise KeyboardInterrupt
        super().reset(ctx)


class InstructedRandom(RandomPolicy):
    """Random policy that keeps the (seed, instruction) of every episode context it is given."""

    name = "instructed-random"

    def __init__(self):
        super().__init__()
        self.seen = []

    def reset(self, ctx):
        self.seen.append((ctx.seed, ctx.instruction))
        super().reset(ctx)


def test_policy_gets_the_episode_instruction_and_the_record_keeps_it(tmp_path):
    pen, out, policy = maniladder_ms.default_catalog().get(PEN), tmp_path / "run", InstructedRandom()
    evaluate(policy, out, tasks=[PEN], episodes=2, obs_mode="state", instructions="paraphrase", progress=False)
    drawn = [(eval_seed(0, k), pen.instruction_for(eval_seed(0, k), "paraphrase")) for k in range(2)]
    assert policy.seen == drawn
    assert sorted((r["seed"], r["instruction"]) for r in read_episodes(out)) == drawn
    assert json.loads((out / "manifest.json").read_text())["instructions"] == "paraphrase"
    with pytest.raises(ResultsError, match="another run.*instructions 'paraphrase' there vs 'canonical' now"):
        evaluate(InstructedRandom(), out, tasks=[PEN], episodes=2, obs_mode="state", progress=False)
    with pytest.raises(ValueError, match="unknown instruction mode 'shuffled'"):
        evaluate(InstructedRandom(), tmp_path / "b", tasks=[PEN], episodes=1, instructions="shuffled", progress=False)
    assert not (tmp_path / "b").exists()


def test_results_from_before_instructions_resume_as_canonical(tmp_path):
    from maniladder_ms.evaluation.results import open_run

    old = {"protocol_version": PROTOCOL_VERSION, "policy": "random", "obs_mode": "state", "seed": 0, "tasks": [PEN]}
    open_run(tmp_path, old)  # a manifest written without the key
    assert open_run(tmp_path, dict(old, instructions="canonical"))["policy"] == "random"
    with pytest.raises(ResultsError, match="another run"):
        open_run(tmp_path, dict(old, instructions="paraphrase"))


def test_resume_after_kill_loses_no_finished_episode(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        evaluate(KilledRandom(kill_at=2), out, tasks=[PEN], episodes=4, obs_mode="state", progress=False)
    before = (out / "episodes.jsonl").read_text().splitlines()
    assert len(before) == 2
    with open(out / "episodes.jsonl", "a") as f:  # a kill in the middle of writing a record
        f.write('{"task": "PickPlacePen", "episode": 2, "succ')
    s = evaluate(KilledRandom(), out, tasks=[PEN], episodes=4, obs_mode="state", progress=False)
    after = (out / "episodes.jsonl").read_text().splitlines()
    assert after[:2] == before  # untouched
    assert sorted(json.loads(x)["episode"] for x in after) == [0, 1, 2, 3]
    assert s["tasks"][PEN]["episodes"] == 4
    # a finished run resumes to a no-op, and more episodes extend it
    evaluate(KilledRandom(), out, tasks=[PEN], episodes=4, obs_mode="state", progress=False)
    assert len((out / "episodes.jsonl").read_text().splitlines()) == 4


def test_results_of_another_protocol_or_run_are_refused(tmp_path):
    out = tmp_path / "run"
    evaluate("random", out, tasks=[PEN], episodes=1, obs_mode="state", progress=False)
    with pytest.raises(ResultsError, match="another run"):
        evaluate("solver", out, tasks=[PEN], episodes=1, progress=False)
    with pytest.raises(ResultsError, match="another run"):
        evaluate("random", out, tasks=[PEN], episodes=1, obs_mode="state", seed=1, progress=False)
    m = json.loads((out / "manifest.json").read_text())
    m["protocol_version"] = PROTOCOL_VERSION + 1
    (out / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ResultsError, match="protocol version"):
        evaluate("random", out, tasks=[PEN], episodes=2, obs_mode="state", progress=False)
    with pytest.raises(ResultsError, match="protocol version"):
        load_results(out)
    assert eval_main(["report", str(out)]) == 2


def _policy_file(tmp_path, body):
    f = tmp_path / "user_policy.py"
    f.write_text(body)
    return str(f)


def test_wrong_action_shape_is_a_clear_error(tmp_path):
    pol = _policy_file(tmp_path, "import numpy as np\ndef policy(obs, spec):\n    return np.zeros(7)\n")
    with pytest.raises(PolicyError, match=r"task PickPlacePen, step 1 \(seed 1000000\).*shape \(7,\)"):
        evaluate(f"{pol}:policy", tmp_path / "out", tasks=[PEN], episodes=1, obs_mode="state", progress=False)
    assert read_episodes(tmp_path / "out") == []


def test_default_obs_is_multiview_rgb_without_state_and_nan_is_caught(tmp_path):
    body = (
        "import json, numpy as np\n"
        "class Policy:\n"
        "    def __init__(self):\n        self.t = 0\n"
        "    def __call__(self, obs, spec):\n"
        "        self.t += 1\n"
        "        if self.t == 1:\n"
        "            cams = {k: list(v) + [list(v['rgb'].shape)] for k, v in obs['sensor_data'].items()}\n"
        "            open(__file__ + '.seen', 'w').write(json.dumps({'keys': sorted(obs), 'cams': cams, 'level': spec.level}))\n"
        "            return np.zeros((2, 8))  # a chunk of two actions\n"
        "        return np.full(8, np.nan)\n"
    )
    pol = _policy_file(tmp_path, body)
    with pytest.raises(PolicyError, match=r"task PickPlacePen, step 3 .*non-finite"):
        evaluate(f"{pol}:Policy", tmp_path / "out", tasks=[PEN], episodes=1, progress=False)
    seen = json.loads(Path(pol + ".seen").read_text())
    assert seen["keys"] == ["sensor_data", "sensor_param"] and seen["level"] == 1
    assert set(seen["cams"]) == {"front_camera", "left_camera", "top_camera", "hand_camera"}
    assert all(v == ["rgb", [1, 128, 128, 3]] for v in seen["cams"].values())


def test_env_driving_policy_is_checked_too(tmp_path):
    body = (
        "import numpy as np\n"
        "class Oracle:\n"
        "    obs_mode = 'state'\n"
        "    def run_episode(self, env, ctx):\n"
        "        env.reset(seed=ctx.seed)\n"
        "        env.step(np.zeros(8))\n"
        "        env.step(np.zeros(3))\n"
    )
    pol = _policy_file(tmp_path, body)
    with pytest.raises(PolicyError, match=r"task PickPlacePen, step 2 .*shape \(3,\)"):
        evaluate(f"{pol}:Oracle", tmp_path / "out", tasks=[PEN], episodes=1, progress=False)


def test_a_diverged_simulation_ends_as_a_failure_marked_diverged(tmp_path):
    """PhysX can diverge under a policy's actions (a rope task's state went NaN at one seed): the episode is a
    failure marked `diverged`, counted in the summary, never a crash blamed on the policy or a scored success."""
    body = (
        "import numpy as np, torch\n"
        "class Breaker:\n"
        "    obs_mode = 'state'\n"
        "    def run_episode(self, env, ctx):\n"
        "        env.reset(seed=ctx.seed)\n"
        "        env.step(np.zeros(8))\n"
        "        env.unwrapped.pen.set_linear_velocity(torch.tensor([[float('nan'), 0.0, 0.0]]))\n"
        "        for _ in range(3):\n"
        "            env.step(np.zeros(8))\n"
    )
    pol = _policy_file(tmp_path, body)
    summary = evaluate(f"{pol}:Breaker", tmp_path / "out", tasks=[PEN], episodes=1, progress=False, bootstrap=0)
    (rec,) = read_episodes(tmp_path / "out")
    assert rec["diverged"] is True and rec["success"] is False
    assert summary["tasks"][PEN]["diverged"] == 1 and summary["tasks"][PEN]["successes"] == 0


def test_unimplemented_tasks_are_refused_or_skipped(tmp_path, capsys, fixture_catalog):
    assert eval_main(["eval", "--policy", "random", "--tasks", FIXTURE_TASK, "--out", str(tmp_path / "a")]) == 2
    assert "not implemented yet" in capsys.readouterr().err
    assert eval_main(["eval", "--policy", "random", "--level", str(FIXTURE_LEVEL), "--out", str(tmp_path / "b")]) == 2
    assert "nothing to evaluate" in capsys.readouterr().err
    assert eval_main(["eval", "--policy", "nonsense", "--tasks", PEN, "--out", str(tmp_path / "c")]) == 2


def mixed_suites(catalog) -> list[tuple[int, str, list[str], set[str]]]:
    """(built count, suite, built ids, unbuilt ids) of each suite with both built and unbuilt tasks."""
    mixed = []
    for suite in sorted({s.suite for s in catalog.tasks}):
        specs = catalog.filter(suite=suite)
        built = [s.id for s in specs if s.implemented]
        unbuilt = {s.id for s in specs if not s.implemented}
        if built and unbuilt:
            mixed.append((len(built), suite, built, unbuilt))
    return mixed


def test_cli_eval_suite_lists_skipped_tasks(tmp_path, capsys, monkeypatch):
    # a suite with built and unbuilt tasks (the one with the fewest built: one random episode each); when every
    # suite is either complete or empty (Levels 1-2 built, 3-4 not, session 20), one of L2-rigid-SG's tasks is
    # unregistered for the test, as a suite looks while it is being built (a Level 2 suite: Level 1 not evaluated)
    catalog = maniladder_ms.default_catalog()
    if not mixed_suites(catalog):
        from mani_skill.utils.registration import REGISTERED_ENVS

        hidden = catalog.filter(suite="L2-rigid-SG")[-1]
        monkeypatch.delitem(REGISTERED_ENVS, hidden.env_id)
    mixed = mixed_suites(catalog)
    assert mixed
    _, suite, built, unbuilt = min(mixed)
    out = tmp_path / "r"
    rc = eval_main(["eval", "--policy", "random", "--suite", suite, "--episodes", "1",
                    "--obs-mode", "state", "--out", str(out), "--quiet"])
    assert rc == 0
    text = capsys.readouterr().out
    assert built[0] in text and "ladder level >= 0" in text and f"skipped {len(unbuilt)} task(s)" in text
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["tasks"] == built and set(manifest["skipped"]) == unbuilt
    assert manifest["protocol_version"] == PROTOCOL_VERSION


def test_replay_policy_plays_recorded_demos(tmp_path):
    import maniladder_ms
    from mani_skill.utils.wrappers.record import RecordEpisode

    from maniladder_ms.solvers import solve

    env = maniladder_ms.make(PEN, obs_mode="state", control_mode="pd_joint_pos")
    env = RecordEpisode(env, output_dir=str(tmp_path / "demos"), save_video=False, trajectory_name="pen",
                        source_type="test", source_desc="scripted solver")
    for seed in (3, 4):
        solve(env, seed)
    env.close()
    h5 = tmp_path / "demos" / "pen.h5"
    assert h5.exists() and h5.with_suffix(".json").exists()
    s = evaluate(f"replay:{h5}", tmp_path / "out", tasks=[PEN], episodes=5, progress=False)
    recs = read_episodes(tmp_path / "out")
    assert [r["seed"] for r in recs] == [3, 4]  # the demos' own seeds; capped at the 2 demos
    assert s["tasks"][PEN]["successes"] == 2
    # a folder of demos works too (hidden work folders are ignored), and tasks without demos are skipped
    import shutil

    (tmp_path / "demos" / ".parts").mkdir()
    for suffix in (".h5", ".json"):
        shutil.copy(h5.with_suffix(suffix), tmp_path / "demos" / ".parts" / f"seeds_0{suffix}")
    pol = load_policy(f"replay:{tmp_path / 'demos'}")
    assert pol.demos["ManiLadder-PickPlacePen-v1"][0] == h5
    assert pol.supports(maniladder_ms.default_catalog().get("Stack6Blocks")) is not True


def _fake_run(path, policy, rates, n=10):
    path.mkdir(parents=True)
    (path / "manifest.json").write_text(json.dumps(
        {"protocol_version": PROTOCOL_VERSION, "policy": policy, "obs_mode": "rgb", "seed": 0, "episodes": n,
         "tasks": list(rates), "skipped": {"HangMug": "not implemented"}}))
    with open(path / "episodes.jsonl", "w") as f:
        for task, rate in rates.items():
            for rec in _records(task, round(rate * n), n):
                f.write(json.dumps(rec) + "\n")


def test_report_renders_with_comparison(tmp_path):
    from PIL import Image

    from maniladder_ms.evaluation.report import write_report

    _fake_run(tmp_path / "a", "random", {PEN: 0.1, "Stack6Blocks": 0.0})
    _fake_run(tmp_path / "b", "mypkg.policies:Diffusion", {PEN: 1.0, "Stack6Blocks": 0.3})
    html_path = write_report([tmp_path / "a", tmp_path / "b"], out=tmp_path / "rep")
    page = html_path.read_text()
    assert page.count("data:image/png;base64,") == 5
    assert "▲" in page and "Table 3" in page and "ladder level" in page
    for name in ("grid", "levels", "tasks", "properties", "deltas"):
        png = tmp_path / "rep" / f"{name}.png"
        assert png.stat().st_size > 5000, name
        img = np.asarray(Image.open(png).convert("RGB"), dtype=float)
        assert img.shape[0] > 200 and img.shape[1] > 300, name
        assert img.std() > 10 and len(np.unique(img.reshape(-1, 3), axis=0)) > 50, f"{name}.png looks blank"
    # a parent folder of runs works too, through the CLI
    assert eval_main(["report", str(tmp_path), "--out", str(tmp_path / "rep2")]) == 0
    assert (tmp_path / "rep2" / "report.html").exists()


@pytest.mark.slow
@pytest.mark.sample
def test_real_kill_and_workers(tmp_path):
    """SIGKILL a 2-worker CLI run mid-way; the resumed run keeps every record and finishes the set."""
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "maniladder_ms.evaluation.cli", "eval", "--policy", "solver", "--tasks", PEN,
           "--episodes", "12", "--workers", "2", "--out", str(out), "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    log = out / "episodes.jsonl"
    deadline = time.time() + 240
    while time.time() < deadline and (not log.exists() or len(log.read_text().splitlines()) < 3):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = [json.loads(x) for x in log.read_text().splitlines() if x.endswith("}")]
    assert 3 <= len(before) < 12
    assert subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode == 0
    after = read_episodes(out)
    assert sorted(r["episode"] for r in after) == list(range(12))
    kept = {(r["episode"], r["seed"], r["success"], r["steps"]) for r in after}
    assert all((r["episode"], r["seed"], r["success"], r["steps"]) in kept for r in before)
    assert sum(r["success"] for r in after) >= 10


def test_add_parsers_plugs_into_the_maniladder_command(tmp_path, capsys):
    import argparse

    from maniladder_ms.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert {"eval", "report"} <= set(sub.choices)
    args = parser.parse_args(["eval", "--policy", "random", "--tasks", "NoSuchTask", "--out", str(tmp_path / "x")])
    assert args.func(args) == 2 and "unknown ManiLadder task" in capsys.readouterr().err
    assert args.instructions == "canonical"
    assert parser.parse_args(["eval", "--policy", "random", "--instructions", "paraphrase"]).instructions == "paraphrase"
    args = parser.parse_args(["report", str(tmp_path / "nothing")])
    assert args.func(args) == 2


# ---- order-independent episodes (protocol 2) ------------------------------------------------------
# CupBeansHands: a cup of beans in two hands, hundreds of resting contacts, so PhysX contact caches left by an
# earlier episode change how an episode plays out (measured: ManiSkill's seeded-sequence check differs by 0.09
# with the scene reused)
ORDER_TASK = "CupBeansHands"
OPEN_LOOP = (
    "import numpy as np\n"
    "class OpenLoop:\n"
    "    '''40 random actions seeded by the episode seed: the same actions for a seed, whatever ran before.'''\n"
    "    obs_mode = 'state'\n"
    "    def run_episode(self, env, ctx):\n"
    "        env.reset(seed=ctx.seed)\n"
    "        rng = np.random.default_rng(ctx.seed)\n"
    "        for _ in range(40):\n"
    "            env.step(rng.uniform(ctx.action_space.low, ctx.action_space.high).astype(np.float32))\n"
)


def test_episode_outcomes_do_not_depend_on_order_or_workers(tmp_path):
    """The same seeds in two orders, and with 1 and 2 worker processes, end in the same states (`state_digest`);
    with the scene reused between seeded resets, the reversed order ends elsewhere (the check can fail)."""
    from maniladder_ms.evaluation.runner import EpisodeRunner

    pol = _policy_file(tmp_path, OPEN_LOOP)
    spec = maniladder_ms.default_catalog().get(ORDER_TASK)
    seeds = [eval_seed(0, k) for k in range(3)]

    def digests(order, fresh=True):
        runner = EpisodeRunner(load_policy(f"{pol}:OpenLoop"))
        try:
            out = {}
            for k in order:
                if runner._env is not None:
                    runner._env.unwrapped.fresh_physics_per_seed = fresh
                out[k] = runner.run(spec, k, seeds[k])["state_digest"]
            return out
        finally:
            runner.close()

    forward = digests([0, 1, 2])
    assert digests([2, 1, 0]) == forward
    assert len(set(forward.values())) == 3
    reused = digests([2, 1, 0], fresh=False)
    assert reused[2] == forward[2] and reused[0] != forward[0]  # episode 2 ran first, in a freshly made env

    by_workers = {}
    for workers in (1, 2):
        evaluate(f"{pol}:OpenLoop", tmp_path / f"w{workers}", tasks=[ORDER_TASK], episodes=3, workers=workers,
                 progress=False)
        by_workers[workers] = {r["episode"]: r["state_digest"] for r in read_episodes(tmp_path / f"w{workers}")}
    assert by_workers[1] == by_workers[2] == forward


def test_report_warns_when_level_means_cover_different_tasks(tmp_path):
    from maniladder_ms.evaluation.report import load_runs, task_set_warnings, write_report

    _fake_run(tmp_path / "a", "random", {PEN: 0.1, "Stack6Blocks": 0.0})
    _fake_run(tmp_path / "b", "solver", {PEN: 1.0, "Stack6Blocks": 0.5})
    _fake_run(tmp_path / "c", "solver", {PEN: 1.0})
    assert task_set_warnings(load_runs([tmp_path / "a", tmp_path / "b"])) == []
    level = maniladder_ms.default_catalog().get("Stack6Blocks").level
    (warning,) = task_set_warnings(load_runs([tmp_path / "a", tmp_path / "c"]))
    assert warning.startswith(f"L{level} means are over different task sets")
    page = write_report([tmp_path / "a", tmp_path / "c"], out=tmp_path / "rep").read_text()
    assert "over different task sets" in page and "design target" in page


def test_replay_policy_reads_the_committed_samples():
    """The committed samples name their env `maniladder_ms:ManiLadder-<Task>-v1` (for replay_trajectory)."""
    repo = Path(__file__).resolve().parents[1]
    pol = load_policy(f"replay:{repo / 'demos' / PEN}")
    assert pol.supports(maniladder_ms.default_catalog().get(PEN)) is True and pol.max_episodes(maniladder_ms.default_catalog().get(PEN)) >= 1


def test_videos_film_the_first_episodes_and_change_no_outcome(tmp_path):
    """`--videos 1`: episode 0 of the task is filmed (a frame per control step and one for the reset, named by its
    outcome, the bar green at the end of a success), episode 1 is not; the episodes' end states are those of a run
    without videos."""
    import imageio_ffmpeg

    task = "PressButtonHand"
    evaluate("solver", tmp_path / "plain", tasks=[task], episodes=2, progress=False, bootstrap=0)
    evaluate("solver", tmp_path / "filmed", tasks=[task], episodes=2, progress=False, bootstrap=0, videos=1)
    evaluate("random", tmp_path / "random", tasks=[task], episodes=1, progress=False, bootstrap=0, videos=1)
    plain, filmed = read_episodes(tmp_path / "plain"), read_episodes(tmp_path / "filmed")
    assert [r["state_digest"] for r in plain] == [r["state_digest"] for r in filmed]
    assert [r["success"] for r in filmed] == [True, True] and "video" not in filmed[1]
    assert filmed[0]["video"] == f"videos/{task}/ep000_seed{eval_seed(0, 0)}_success.mp4"
    assert sorted(p.name for p in (tmp_path / "filmed" / "videos" / task).iterdir()) == [Path(filmed[0]["video"]).name]
    reader = imageio_ffmpeg.read_frames(str(tmp_path / "filmed" / filmed[0]["video"]))
    meta = next(reader)
    frames = [np.frombuffer(f, np.uint8).reshape(meta["size"][1], meta["size"][0], 3) for f in reader]
    # a frame for the reset and one per control step (the solver holds a few steps past its first success); the bar
    # under the frame turns green at the step the record gives as the first success
    k = filmed[0]["steps"]
    assert len(frames) > k and meta["size"][0] == 512
    bar = lambda frame: frame[-4:, :100].reshape(-1, 3).mean(0)  # noqa: E731  (the bar's left end)
    grey, green = bar(frames[k - 1]), bar(frames[k])
    assert bar(frames[0]).max() < 60 and grey.min() > 150 and green[0] < 90 < 150 < green[1], (grey, green)
    (rnd,) = read_episodes(tmp_path / "random")
    assert not rnd["success"] and rnd["video"].endswith("_failure.mp4") and (tmp_path / "random" / rnd["video"]).is_file()
    for bad, why in ((dict(videos=-1), "--videos must be >= 0"), (dict(videos=1, ray_address="local"), "without --ray")):
        with pytest.raises(ValueError, match=why):
            evaluate("random", tmp_path / "bad", tasks=[task], episodes=1, progress=False, **bad)
