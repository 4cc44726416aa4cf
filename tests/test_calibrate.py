"""`maniladder calibrate`: levels from rates, and a whole (tiny) calibration that survives a kill."""

import dataclasses
import json
import os
import signal
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from maniladder_ms.evaluation import eval_seed
from maniladder_ms.policy.calibrate import (CalibrationProtocol, ResultExistsError, TaskCalibration, calibrate,
                                            measured_level, verdict)
from maniladder_ms.policy.flow import LadderFlowConfig

from conftest import FIXTURE_TASK

REPO = Path(__file__).resolve().parents[1]

# the committed PickPlacePen samples (2 demos), a random-projection encoder and a tiny network: every stage
# runs for real, in seconds, and solves nothing
TINY = LadderFlowConfig(encoder="random-projection", d_model=32, heads=2, encoder_layers=1, decoder_layers=1,
                        dropout=0.0, batch_size=16, train_steps=6)
# two checkpoints (the selection stage runs) and two training seeds (pooled)
TINY_PROTOCOL = CalibrationProtocol(demos=2, frame_stride=4, checkpoints=2, selection_episodes=1, episodes=1,
                                    training_seeds=2)


def test_measured_level_follows_the_catalog_intervals():
    # L1 [60, 85] %, L2 [20, 60) %, L3 (0, 20) %, L4 0 %; above L1's interval: 0 (easier than Level 1)
    cases = {0.0: 4, 0.05: 3, 0.199: 3, 0.2: 2, 0.59: 2, 0.6: 1, 0.85: 1, 0.86: 0, 1.0: 0}
    assert {r: measured_level(r) for r in cases} == cases


def test_verdict_places_the_interval_against_the_catalog_band():
    # L1 [60, 85] %: 36/50 = 72 % [58, 83] straddles 60; 72/100 [62, 80] is inside; 10/50 is outside
    assert verdict(36, 50, 1) == "straddles" and verdict(72, 100, 1) == "inside" and verdict(10, 50, 1) == "outside"
    assert verdict(0, 50, 4) == "inside" and verdict(1, 50, 4) == "outside" and verdict(40, 50, 4) == "outside"
    assert verdict(0, 50, 3) == "straddles" and verdict(3, 100, 3) == "inside" and verdict(30, 50, 3) == "outside"
    assert verdict(95, 100, 1) == "outside"  # easier than Level 1


def test_development_and_final_runs_use_their_own_seed_sets_never_the_retired_one():
    from maniladder_ms.policy.calibrate import RETIRED_SEED_SETS, SEED_SETS

    dev, final = CalibrationProtocol(purpose="development"), CalibrationProtocol()
    assert dev.seeds == [0] and final.seeds == [0, 1, 2]
    assert dev.seed_set != final.seed_set and not {dev.seed_set, final.seed_set} & set(RETIRED_SEED_SETS)
    assert set(SEED_SETS.values()).isdisjoint(RETIRED_SEED_SETS)
    with pytest.raises(ValueError, match="purpose"):
        CalibrationProtocol(purpose="tuning")


def test_calibrating_an_unbuilt_task_is_a_clear_error(tmp_path, fixture_catalog):
    import maniladder_ms

    catalog, unbuilt = fixture_catalog, FIXTURE_TASK
    with pytest.raises(maniladder_ms.TaskNotImplementedError, match="not implemented"):
        TaskCalibration(unbuilt, tmp_path / "work", tmp_path / "out")

    # the command says so in one line (exit 2), and so for a suite with nothing built
    from maniladder_ms.cli import main

    empty = catalog.get(unbuilt).suite  # every row of the fixture level is made up
    assert not any(t.implemented for t in catalog.filter(suite=empty))
    for args in (["--tasks", unbuilt], ["--suite", empty]):
        assert main(["calibrate", *args, "--work", str(tmp_path / "w"), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "w").exists() and not (tmp_path / "o").exists()


_CHILD = """
import sys, torch
torch.set_num_threads(1)
from pathlib import Path
sys.path.insert(0, {tests!r})
from test_calibrate import TINY, TINY_PROTOCOL
from maniladder_ms.policy.calibrate import calibrate
calibrate(["PickPlacePen"], Path({work!r}), Path({out!r}), demos_dir=Path({demos!r}), config=TINY,
          protocol=TINY_PROTOCOL, progress=False)
"""


def test_calibrate_resumes_after_a_kill(tmp_path, monkeypatch):
    """Kill a calibration once its first seed's checkpoints exist and selection has begun; the re-run keeps the
    features and checkpoints, finishes both training seeds, and writes the task's pooled result with its
    provenance, the table and the plot. The work folder is the task version's: a changed task starts afresh."""
    from maniladder_ms import provenance
    from maniladder_ms.policy.revalidate import demos_digest

    work, out = tmp_path / "work", tmp_path / "out"
    task_dir = work / "PickPlacePen" / provenance.task_hash("PickPlacePen")
    code = _CHILD.format(tests=str(REPO / "tests"), work=str(work), out=str(out), demos=str(REPO / "demos"))
    child = subprocess.Popen([sys.executable, "-c", code], cwd=tmp_path, start_new_session=True,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        # wait for the selection stage's first episode file, then kill the whole process group
        while child.poll() is None and not list(task_dir.glob("seed_0/select_*/episodes.jsonl")):
            time.sleep(0.2)
        assert child.poll() is None, f"the calibration ended before it could be killed: {child.stderr.read().decode()[-2000:]}"
        os.killpg(child.pid, signal.SIGKILL)
        child.wait()
    finally:
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
    assert not (out / "PickPlacePen.json").exists()

    def kept_files():
        return {p.relative_to(task_dir).as_posix(): p.stat().st_mtime_ns
                for p in [task_dir / "features.npz", *task_dir.glob("seed_*/checkpoint_*.pt")]}

    kept = kept_files()
    assert set(kept) == {"features.npz", "seed_0/checkpoint_3.pt", "seed_0/checkpoint_6.pt"}
    timings_before = json.loads((task_dir / "timings.json").read_text())

    summary = calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=TINY_PROTOCOL,
                        progress=False, videos=1)

    # each training seed's evaluation filmed its first episode (`--videos 1`); the selection stage films nothing
    films = sorted(p.relative_to(task_dir).as_posix() for p in task_dir.rglob("*.mp4"))
    assert [f.split("/videos/")[0] for f in films] == ["seed_0/final", "seed_1/final"], films
    assert all(f.split("/")[-1].startswith(f"ep000_seed{eval_seed(2, 0)}_") for f in films), films
    assert {k: v for k, v in kept_files().items() if k in kept} == kept
    assert set(kept_files()) == set(kept) | {"seed_1/checkpoint_3.pt", "seed_1/checkpoint_6.pt"}
    timings = json.loads((task_dir / "timings.json").read_text())
    assert timings["features"] == timings_before["features"]
    result = json.loads((out / "PickPlacePen.json").read_text())
    # a 6-step policy, its episodes pooled over the two training seeds: the level, agreement and verdict its
    # successes give (the mean of the demos' joint targets can pick PickPlacePen's pen on its one-sided layout)
    k = result["successes"]
    assert result["episodes"] == 2 and result["measured_level"] == measured_level(k / 2)
    assert set(result["per_training_seed"]) == {"0", "1"}
    assert result["training_seed_spread"]["max"] == max(v["success"] for v in result["per_training_seed"].values())
    assert result["agree"] is (result["measured_level"] == 1) and result["catalog_level"] == 1
    assert result["verdict"] == verdict(k, 2, 1) and result["purpose"] == "final" and result["seed_set"] == 2
    assert result["per_training_seed"]["0"]["selection"]["selected_step"] in (3, 6)
    assert set(result["reached"]) == {"0", "1"} and all(0 <= share <= 1 for r in result["reached"].values()
                                                           for share in r.values())
    assert result["demos_digest"] == demos_digest(REPO / "demos" / "PickPlacePen" / "trajectory.none.pd_joint_pos.physx_cpu.h5")
    assert result["control_mode"] == "pd_joint_pos" and result["config"]["encoder"] == "random-projection"
    env = result["environment"]
    assert result["task_hash"] == provenance.task_hash("PickPlacePen") and env["renderer"] == "cpu"
    assert env["torch_threads"] == 1 and env["packages"]["mani-skill"] and "commit" in env
    assert summary["n_tasks"] == 1 and (out / "calibration.json").is_file() and (out / "calibration.png").stat().st_size > 0

    # the work folder belongs to its settings, the declared episode count included: no growing after a look
    for config, protocol in ((dataclasses.replace(TINY, train_steps=8), TINY_PROTOCOL),
                             (TINY, dataclasses.replace(TINY_PROTOCOL, episodes=2))):
        with pytest.raises(ValueError, match="other settings"):
            calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=config, protocol=protocol,
                      progress=False)
    # the purpose picks only the evaluation's seed set and folder: a development run of the same version trains
    # nothing new (training seed 0, features and demos are the final run's) and evaluates into seed_0/development
    kept = kept_files()
    dev = calibrate(["PickPlacePen"], work, tmp_path / "dev", demos_dir=REPO / "demos", config=TINY,
                    protocol=dataclasses.replace(TINY_PROTOCOL, purpose="development"), progress=False)
    assert kept_files() == kept and dev["n_tasks"] == 1
    dev_result = json.loads((tmp_path / "dev" / "PickPlacePen.json").read_text())
    assert dev_result["purpose"] == "development" and set(dev_result["per_training_seed"]) == {"0"}
    assert (task_dir / "seed_0" / "development" / "episodes.jsonl").is_file()
    assert not (task_dir / "seed_1" / "development").exists()
    # a re-run of the finished task leaves its result file as it was (no new time stamp to commit)
    finished = (out / "PickPlacePen.json").read_bytes()
    calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=TINY_PROTOCOL, progress=False)
    assert (out / "PickPlacePen.json").read_bytes() == finished
    # another result in the results folder (an older protocol's, committed) is not overwritten without --replace
    old = dict(json.loads(finished), protocol="v3", task_hash=None)
    (out / "PickPlacePen.json").write_text(json.dumps(old))
    with pytest.raises(ResultExistsError, match="--replace"):
        calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=TINY_PROTOCOL,
                  progress=False)
    assert json.loads((out / "PickPlacePen.json").read_text())["protocol"] == "v3"
    calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=TINY_PROTOCOL,
              progress=False, replace=True)
    replaced = json.loads((out / "PickPlacePen.json").read_text())
    assert replaced["protocol"] == result["protocol"] and replaced["task_hash"] == result["task_hash"]

    # `maniladder report` shows a calibration folder, older protocols labelled
    from maniladder_ms.cli import main

    assert main(["report", str(out)]) == 0
    assert "PickPlacePen" in (out / "report" / "report.html").read_text()

    # a changed task (another version hash) gets a fresh work folder: nothing of the old version is reused
    monkeypatch.setattr(provenance, "task_hash", lambda task_id: "0123456789abcdef")
    changed = TaskCalibration("PickPlacePen", work, out, demos_dir=REPO / "demos", config=TINY, protocol=TINY_PROTOCOL)
    assert changed.dir == work / "PickPlacePen" / "0123456789abcdef" and not changed.features_path.exists()


def test_the_committed_calibration_report_labels_protocols_and_stale_rows(tmp_path, capsys):
    from maniladder_ms.policy.calibrate import write_calibration_report

    write_calibration_report(REPO / "docs" / "calibration", out=tmp_path)
    text = capsys.readouterr().out
    assert "LadderFlow v3 (superseded by v4: not comparable)" in text
    # newest protocol first: the v4 development runs (labelled as such), then v3, the folder's own results
    assert text.startswith("LadderFlow v4 development runs in development/ (current protocol; one training seed")
    dev, v3 = text.split("LadderFlow v3 (superseded")
    stale = {line.split(":")[0].removeprefix("STALE ") for line in v3.splitlines() if line.startswith("STALE ")}
    assert stale == {"LiftBasketHands", "LiftBottleHand", "LiftRopeHand", "StretchRopeHands"}
    # every task result committed there (the folder's own summary, calibration.json, is not one)
    from maniladder_ms.policy.calibrate import load_results

    committed = {r["task"] for r in load_results(REPO / "docs" / "calibration" / "development", protocol=None)}
    assert committed == {p.stem for p in (REPO / "docs" / "calibration" / "development").glob("*.json")
                         if p.name != "calibration.json"}
    shown = {line.split()[0] for line in dev.splitlines()[1:] if line.split() and line.split()[0] in committed}
    assert shown == committed and "development" in dev.splitlines()[3]


def test_task_hash_follows_the_task_version():
    from maniladder_ms import provenance

    parts = provenance.task_hash_parts("PickPlacePen")
    assert "maniladder_ms/tasks/rigid/pick_place_pen.py" in parts and "maniladder_ms/solvers/rigid/pick_place_pen.py" in parts
    assert "maniladder_ms/tasks/rigid/hang_mug.py" not in parts  # another task's module is not this task's version
    assert provenance.task_hash("PickPlacePen") != provenance.task_hash("HangMug")
    assert len(provenance.task_hash("PickPlacePen")) == 16


def test_results_of_another_protocol_are_not_summarised(tmp_path):
    from maniladder_ms.policy.calibrate import load_results

    (tmp_path / "Old.json").write_text(json.dumps({"task": "Old", "measured_level": 3, "protocol": "v0"}))
    assert load_results(tmp_path) == []


def halved(low_high: tuple[float, float]) -> tuple[float, float]:
    """The range about the same middle, half as wide (`randomisation_pilot --scale 0.5`), widened by 1e-6 for
    float32 rounding."""
    lo, hi = low_high
    return (3 * lo + hi) / 4 - 1e-6, (lo + 3 * hi) / 4 + 1e-6


def within(value: float, low_high: tuple[float, float]) -> bool:
    return low_high[0] <= value <= low_high[1]


def test_randomisation_pilot_draws_pick_place_pen_layouts_from_the_narrowed_ranges():
    # scripts/randomisation_pilot.py replaces PickPlacePen's layout draw in its own process; here the draw is
    # checked against the halved ranges on one side, and the registered task's draw is restored afterwards
    sys.path.insert(0, str(REPO / "scripts"))
    import randomisation_pilot

    import maniladder_ms
    from maniladder_ms.geometry import actor_yaw
    from maniladder_ms.tasks.rigid.pick_place_pen import PickPlacePenEnv

    registered = PickPlacePenEnv._initialize_episode
    params = maniladder_ms.default_catalog().get("PickPlacePen").params
    try:
        randomisation_pilot.pick_place_pen_one_side(scale=0.5)
        env = maniladder_ms.make("PickPlacePen", obs_mode="state")
        task = env.unwrapped
        for seed in range(8):
            env.reset(seed=seed)
            pen, tray = task.pen.pose.p[0].tolist(), task.tray.pose.p[0].tolist()
            assert within(pen[0], halved(params["pen_x_range"])) and within(pen[1], halved(params["pen_y_range"]))
            # the tray on the other side
            assert within(tray[0], halved(params["tray_x_range"])) and within(tray[1], halved(params["tray_y_range"]))
            assert abs(actor_yaw(task.tray)) <= np.deg2rad(params["tray_max_yaw"]) / 2 + 1e-4
        env.close()
    finally:
        PickPlacePenEnv._initialize_episode = registered


def test_randomisation_pilot_shrinks_every_uniform_layout_draw_about_its_middle():
    sys.path.insert(0, str(REPO / "scripts"))
    import randomisation_pilot

    import maniladder_ms
    from maniladder_ms.tasks.rigid.hang_mug import HangMugEnv

    registered = HangMugEnv._initialize_episode
    params = maniladder_ms.default_catalog().get("HangMug").params
    try:
        randomisation_pilot.shrink_layout_draws("HangMug", 0.5)
        env = maniladder_ms.make("HangMug", obs_mode="state")
        for seed in range(8):
            env.reset(seed=seed)
            mug, tree = env.unwrapped.mug.pose.p[0].tolist(), env.unwrapped.tree.pose.p[0].tolist()
            assert within(mug[0], halved(params["mug_x_range"])) and within(mug[1], halved(params["mug_y_range"]))
            assert within(tree[0], halved(params["tree_x_range"])) and within(tree[1], halved(params["tree_y_range"]))
        env.close()
    finally:
        HangMugEnv._initialize_episode = registered
    assert maniladder_ms.make("HangMug", obs_mode="state").unwrapped._initialize_episode.__func__ is registered


def test_training_killed_between_resume_points_ends_in_the_same_weights(tmp_path, monkeypatch):
    """Training saves a resume point every RESUME_EVERY steps; killed after two of them and run again, it ends in
    the weights of an uninterrupted run, and the resume point is gone once the checkpoint exists."""
    import torch

    import maniladder_ms.policy.calibrate as cal
    from maniladder_ms.policy.flow import LadderFlowPolicy, LadderFlowTrainer

    monkeypatch.setattr(cal, "RESUME_EVERY", 2)
    protocol = CalibrationProtocol(demos=2, checkpoints=1, training_seeds=1, purpose="development")
    rng = np.random.default_rng(0)
    arrays = {}
    for i in range(2):  # features (F, 3 cameras x 2x2 cells, 16), all actions (T, 8), the frames they were taken at
        arrays[f"features_{i}"] = rng.normal(size=(10, 12, 16)).astype(np.float16)
        arrays[f"frames_{i}"] = np.arange(0, 20, 2)
        arrays[f"actions_{i}"] = rng.normal(size=(20, 8)).astype(np.float32)
        # the protocol's random-shift copies of every frame (training draws the frame or a copy: RNG state to resume)
        arrays[f"augmented_{i}"] = rng.normal(size=(TINY.augment_copies, 10, 12, 16)).astype(np.float16)

    def calibration(name):
        tc = TaskCalibration("PickPlacePen", tmp_path / name, tmp_path / "out", config=TINY, protocol=protocol,
                             progress=False)
        tc.features_path.parent.mkdir(parents=True)
        np.savez(tc.features_path, seeds=np.arange(2), **arrays)
        return tc

    whole = calibration("whole")
    whole.stage_train(0)
    killed = calibration("killed")
    train = LadderFlowTrainer.train
    calls = []

    def dies_on_third_chunk(self, steps, progress=False):
        calls.append(steps)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return train(self, steps, progress)

    monkeypatch.setattr(LadderFlowTrainer, "train", dies_on_third_chunk)
    with pytest.raises(KeyboardInterrupt):
        killed.stage_train(0)
    assert cal.torch_step(killed.seed_dir(0) / "resume.pt") == 4 and not killed.checkpoint(6).exists()
    monkeypatch.setattr(LadderFlowTrainer, "train", train)
    killed.stage_train(0)
    assert not (killed.seed_dir(0) / "resume.pt").exists()
    a, b = (LadderFlowPolicy.load(tc.checkpoint(6)).net.state_dict() for tc in (whole, killed))
    assert all(torch.equal(a[k], b[k]) for k in a)


def _result(task_hash="aaaa", purpose="development", successes=30, config=None):
    """A `write_result`-shaped result of PickPlacePen (only the fields a record reads)."""
    return {"task": "PickPlacePen", "task_hash": task_hash, "protocol": "v4", "purpose": purpose,
            "seed_set": 1 if purpose == "development" else 2, "config": config or {"train_steps": 4000},
            "catalog_level": 1, "horizon": 200, "successes": successes, "episodes": 50, "success": successes / 50,
            "ci95": [0.4, 0.7], "measured_level": 2, "verdict": "outside", "per_training_seed": {"0": {}},
            "environment": {"commit": "abc1234"}, "time": "2026-11-29T18:00:00"}


def test_calibration_record_keeps_rounds_changes_and_the_loop_limit(tmp_path):
    """The refinement loop's record: a resumed run adds nothing, a changed task says what changed (the params'
    diff is recorded with the reason), a fifth development round is refused without --extra-round, the final run
    is recorded after the rounds."""
    from maniladder_ms.policy.records import MAX_DEVELOPMENT_ROUNDS, RecordError, load_record, record_lines, record_run

    params = {"pen_x_range": [-0.1, 0.1]}
    record_run(tmp_path, _result(), params)
    record_run(tmp_path, _result(), params)  # the same task version again: a resume
    assert len(load_record(tmp_path, "PickPlacePen")["entries"]) == 1
    with pytest.raises(RecordError, match="--change"):
        record_run(tmp_path, _result(task_hash="bbbb"), {"pen_x_range": [-0.05, 0.05]})
    record = record_run(tmp_path, _result(task_hash="bbbb", successes=36), {"pen_x_range": [-0.05, 0.05]},
                        reason="halved pen_x_range: 30/50 with the full range")
    second = record["entries"][1]
    assert second["round"] == 2 and second["change"] == {"pen_x_range": [[-0.1, 0.1], [-0.05, 0.05]]}
    assert "halved" in second["reason"] and second["commit"] == "abc1234"
    for k in range(3, MAX_DEVELOPMENT_ROUNDS + 1):
        record_run(tmp_path, _result(task_hash=f"h{k}"), params, reason=f"round {k}")
    with pytest.raises(RecordError, match="development rounds"):
        record_run(tmp_path, _result(task_hash="h9"), params, reason="one more")
    record_run(tmp_path, _result(task_hash="h9"), params, reason="one more, because", extra_round=True)
    record = record_run(tmp_path, _result(task_hash="h9", purpose="final", successes=40), params)
    assert [e["purpose"] for e in record["entries"]][-2:] == ["development", "final"]
    lines = record_lines(record)
    assert len(lines) == MAX_DEVELOPMENT_ROUNDS + 2 and "pen_x_range [-0.1, 0.1] -> [-0.05, 0.05]" in lines[1]
    assert lines[-1].startswith(f"{MAX_DEVELOPMENT_ROUNDS + 2}. final (v4, seed set 2")


def test_calibrate_checks_the_record_before_any_work_and_show_prints_it(tmp_path, monkeypatch, capsys):
    """`maniladder calibrate --record` refuses a changed task without --change before it makes anything;
    `maniladder show` prints the committed record's entries."""
    import maniladder_ms.policy.records as records
    from maniladder_ms.cli import main
    from maniladder_ms.policy.records import record_run

    record_run(tmp_path / "records", _result(task_hash="0000000000000000"), {})
    work = tmp_path / "work"
    assert main(["calibrate", "--tasks", "PickPlacePen", "--purpose", "development", "--work", str(work),
                 "--out", str(tmp_path / "out"), "--record", str(tmp_path / "records"), "--quiet"]) == 2
    assert "changed since its last recorded run" in capsys.readouterr().err and not work.exists()
    monkeypatch.setattr(records, "COMMITTED_RECORDS", tmp_path / "records")
    assert main(["show", "PickPlacePen"]) == 0
    out = capsys.readouterr().out
    assert "1 recorded run(s)" in out and "1. development (v4, seed set 1, 1 training seed(s), task version " \
        "0000000000000000): 30/50 = 60% [40, 70], interval outside L1's band" in out


def test_calibrate_records_each_task_as_it_finishes(tmp_path, monkeypatch):
    """A run over several tasks appends each task's record when its result is written, before the next task starts
    (a run of the ladder takes days: a killed run keeps the records of the tasks it finished)."""
    from maniladder_ms.cli import main
    from maniladder_ms.policy import calibrate as cal
    from maniladder_ms.policy.records import load_record
    from maniladder_ms.provenance import task_hash

    tasks, seen = ["PickPlacePen", "LiftWideBox"], []

    def run(self):  # the calibration's stages stood in for: the result file a finished task writes
        task = self.spec.id
        seen.append([t for t in tasks if load_record(tmp_path / "records", t)["entries"]])
        r = {**_result(task_hash=task_hash(task)), "task": task}
        self.out.mkdir(parents=True, exist_ok=True)
        (self.out / f"{task}.json").write_text(json.dumps(r))
        return {**r, "successes": 30, "episodes": 50, "ci95": [0.4, 0.7], "measured_level_text": "L2",
                "catalog_level": 1}

    monkeypatch.setattr(cal.TaskCalibration, "run", run)
    monkeypatch.setattr(cal, "write_summary", lambda out: {"tasks": []})
    monkeypatch.setattr(cal, "print_calibration", lambda summary, file=None: None)
    assert main(["calibrate", "--tasks", ",".join(tasks), "--purpose", "development", "--work", str(tmp_path / "w"),
                 "--out", str(tmp_path / "out"), "--record", str(tmp_path / "records"), "--quiet"]) == 0
    assert seen == [[], ["PickPlacePen"]]  # the first task's record was there when the second started
    assert all(len(load_record(tmp_path / "records", t)["entries"]) == 1 for t in tasks)  # and nothing twice


def test_a_result_of_an_earlier_version_stands_for_the_current_one_only_if_its_demos_come_out_the_same(tmp_path):
    """`calibrate --revalidate`: a result measured on another version of a task (its hash differs: a shared module
    was edited) stands for the current version when the task's own parts are unchanged since the result's commit
    and its demos, regenerated now, are bit-identical to those it was trained on; with one action altered in those
    demos it stays stale. The record then accepts a run of the current version without --change."""
    import h5py

    from maniladder_ms.cli import main
    from maniladder_ms.demos.files import demo_path
    from maniladder_ms.demos.recording import generate
    from maniladder_ms.policy import calibrate as cal
    from maniladder_ms.policy import revalidate as rv
    from maniladder_ms.policy.records import check_run, record_run
    from maniladder_ms.provenance import task_hash

    head = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    if not head:
        pytest.skip("not a git checkout")
    with pytest.raises(ValueError, match="does not name"):
        rv.own_parts_changed("PickPlacePen", head + "+dirty")
    assert rv.own_parts_changed("PickPlacePen", head) == []
    # a result from a checkout with uncommitted edits measured its commit's task if the task's hash there is its own
    at_head = rv.task_hash_at(head, "PickPlacePen")
    assert rv.measured_commit("PickPlacePen", head + "+dirty", at_head) == head
    with pytest.raises(ValueError, match="uncommitted edits changed it"):
        rv.measured_commit("PickPlacePen", head + "+dirty", "0123456789abcdef")
    with pytest.raises(ValueError, match="records no commit"):
        rv.measured_commit("PickPlacePen", "", at_head)
    # a dirty result whose task's catalog row changed since is stale whatever its edits were: `changed`, not unknown
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(rv, "row_changed_since", lambda task_id, commit: True)
        assert rv.measured_commit("PickPlacePen", head + "+dirty", "0123456789abcdef") == head
        assert rv.own_parts_changed("PickPlacePen", head) == ["its catalog row"]
    task, old, mode = "PickPlacePen", "0123456789abcdef", cal.demo_control_mode_for("PickPlacePen")
    work, out = tmp_path / "work", tmp_path / "out"
    generate(task, 2, work / task / old / "demos", seed=0, control_mode=mode, progress=False)
    result = {**_result(task_hash=old), "measured_level_text": "L2", "agree": False, "environment": {"commit": head},
              "calibration": {"demos": 2, "demo_seed": 0}, "demo_control_mode": mode}
    out.mkdir()
    (out / f"{task}.json").write_text(json.dumps(result))
    record_run(tmp_path / "records", result, {})
    assert cal.stale_reason(result) is not None
    args = ["calibrate", "--tasks", task, "--revalidate", "--work", str(work), "--out", str(out), "--quiet"]
    assert main(args + ["--record", str(tmp_path / "records")]) == 0
    now = json.loads((out / f"{task}.json").read_text())
    assert [e["task_hash"] for e in now["equivalent_versions"]] == [task_hash(task)] and cal.stale_reason(now) is None
    check_run(tmp_path / "records", task, task_hash(task), "v4", "final", {"train_steps": 4000})  # no --change needed
    trained_on = demo_path(work / task / old / "demos", task, "none", mode)
    assert now["demos_digest"] == rv.demos_digest(trained_on)  # kept: later checks need no work folder
    assert main(args) == 0  # revalidated already: current
    (out / f"{task}.json").write_text(json.dumps(result))  # the same result again, its demos altered by one action
    with h5py.File(trained_on, "r+") as f:
        f["traj_1"]["actions"][3, 0] += 1e-3
    assert main(args) == 1
    assert "equivalent_versions" not in json.loads((out / f"{task}.json").read_text())

    shutil.rmtree(work)  # the work folder lost: the recorded digest decides alone
    (out / f"{task}.json").write_text(json.dumps({**result, "demos_digest": now["demos_digest"]}))
    assert main(args) == 0
    assert [e["task_hash"] for e in json.loads((out / f"{task}.json").read_text())["equivalent_versions"]] == \
        [task_hash(task)]
    (out / f"{task}.json").write_text(json.dumps(result))  # neither a digest nor the demos: cannot tell, untouched
    assert main(args) == 1 and json.loads((out / f"{task}.json").read_text()) == result
    current = {**result, "task_hash": task_hash(task)}  # written before results carried a digest: it gets one
    (out / f"{task}.json").write_text(json.dumps(current))
    assert main(args) == 0
    assert json.loads((out / f"{task}.json").read_text()) == {**current, "demos_digest": now["demos_digest"]}


def test_calibration_report_shows_level_means_agreement_and_the_ladder_figures(tmp_path, capsys):
    """The ladder's picture from calibration results: level means with bootstrap intervals and whether adjacent
    levels are apart, the agreement table (catalog level x measured level), and four figures."""
    import maniladder_ms
    from maniladder_ms.policy.calibrate import write_calibration_report

    rows = {"PickPlacePen": (1, 36, 1), "LiftWideBox": (1, 48, 0), "InsertPegInHole": (2, 15, 2),
            "PlaceMugOnCoasterHand": (2, 20, 2)}  # task: (catalog level, successes of 50, measured level)
    for task, (level, k, measured) in rows.items():
        (tmp_path / f"{task}.json").write_text(json.dumps({
            "task": task, "suite": maniladder_ms.default_catalog().get(task).suite, "catalog_level": level, "purpose": "final",
            "successes": k, "episodes": 50, "success": k / 50, "ci95": [0.0, 1.0], "measured_level": measured,
            "measured_level_text": f"L{measured}", "agree": measured == level, "verdict": "inside",
            "demo_mean_steps": 100.0, "protocol": "v4"}))
    page = write_calibration_report(tmp_path, out=tmp_path / "report").read_text()
    text = capsys.readouterr().out
    assert page.count("<img ") == 4
    assert "L1: 84% [" in text and "L2: 35% [" in text and "L1 above L2 with intervals apart: yes" in text
    table = text[text.index("agreement"):].splitlines()
    assert table[1].split() == ["M0", "M1", "M2"] and table[2].split() == ["L1", "1", "1", "0"] \
        and table[3].split() == ["L2", "0", "0", "2"]
