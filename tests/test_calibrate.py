"""`maniladder calibrate`: levels from rates, and a whole (tiny) calibration that survives a kill."""

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from maniladder_ms.policy.calibrate import CalibrationProtocol, TaskCalibration, calibrate, measured_level
from maniladder_ms.policy.flow import LadderFlowConfig

from conftest import FIXTURE_TASK

REPO = Path(__file__).resolve().parents[1]

# the committed PickPlacePen samples (2 demos), a random-projection encoder and a tiny network: every stage
# runs for real, in seconds, and solves nothing
TINY = LadderFlowConfig(encoder="random-projection", d_model=32, heads=2, encoder_layers=1, decoder_layers=1,
                        dropout=0.0, batch_size=16, train_steps=6)
TINY_PROTOCOL = CalibrationProtocol(demos=2, frame_stride=4, checkpoints=2, selection_episodes=1, episodes=1)


def test_measured_level_follows_the_catalog_intervals():
    # L1 [60, 85] %, L2 [20, 60) %, L3 (0, 20) %, L4 0 %; above L1's interval: 0 (easier than Level 1)
    cases = {0.0: 4, 0.05: 3, 0.199: 3, 0.2: 2, 0.59: 2, 0.6: 1, 0.85: 1, 0.86: 0, 1.0: 0}
    assert {r: measured_level(r) for r in cases} == cases


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


def test_calibrate_resumes_after_a_kill(tmp_path):
    """Kill a calibration once its checkpoints exist and selection has begun; the re-run keeps the features
    and checkpoints, finishes, and writes the task's result, the table and the plot."""
    work, out = tmp_path / "work", tmp_path / "out"
    task_dir = work / "PickPlacePen"
    code = _CHILD.format(tests=str(REPO / "tests"), work=str(work), out=str(out), demos=str(REPO / "demos"))
    child = subprocess.Popen([sys.executable, "-c", code], cwd=tmp_path, start_new_session=True,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        # wait for the selection stage's first episode file, then kill the whole process group
        while child.poll() is None and not list(task_dir.glob("select_*/episodes.jsonl")):
            time.sleep(0.2)
        assert child.poll() is None, f"the calibration ended before it could be killed: {child.stderr.read().decode()[-2000:]}"
        os.killpg(child.pid, signal.SIGKILL)
        child.wait()
    finally:
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGKILL)
    assert not (out / "PickPlacePen.json").exists()
    kept = {p.name: p.stat().st_mtime_ns for p in [task_dir / "features.npz", *task_dir.glob("checkpoint_*.pt")]}
    assert set(kept) == {"features.npz", "checkpoint_3.pt", "checkpoint_6.pt"}
    timings_before = json.loads((task_dir / "timings.json").read_text())

    summary = calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=TINY_PROTOCOL,
                        progress=False)

    assert {p.name: p.stat().st_mtime_ns for p in [task_dir / "features.npz", *task_dir.glob("checkpoint_*.pt")]} == kept
    timings = json.loads((task_dir / "timings.json").read_text())
    assert timings["features"] == timings_before["features"] and timings["train"] == timings_before["train"]
    result = json.loads((out / "PickPlacePen.json").read_text())
    assert result["episodes"] == 1 and result["successes"] == 0 and result["measured_level"] == 4
    assert result["agree"] is False and result["catalog_level"] == 1  # a 6-step policy solves nothing: flagged
    assert result["selection"]["selected_step"] in (3, 6) and set(result["selection"]["selection_rates"]) == {"3", "6"}
    assert result["control_mode"] == "pd_joint_pos" and result["demo_control_mode"] == "pd_joint_pos" and result["config"]["encoder"] == "random-projection"
    assert summary["n_tasks"] == 1 and (out / "calibration.json").is_file() and (out / "calibration.png").stat().st_size > 0

    # the work folder belongs to its settings: another configuration is refused, not mixed in
    with pytest.raises(ValueError, match="other settings"):
        calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=dataclasses.replace(TINY, train_steps=8),
                  protocol=TINY_PROTOCOL, progress=False)

    # more evaluation episodes on the same work folder: the evaluation resumes and adds them; nothing retrains
    more = dataclasses.replace(TINY_PROTOCOL, episodes=2)
    calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=more, progress=False)
    assert {p.name: p.stat().st_mtime_ns for p in [task_dir / "features.npz", *task_dir.glob("checkpoint_*.pt")]} == kept
    assert json.loads((out / "PickPlacePen.json").read_text())["episodes"] == 2
    assert json.loads((task_dir / "settings.json").read_text())["calibration"]["episodes"] == 2
    # a re-run of the finished task leaves its result file as it was (no new time stamp to commit)
    finished = (out / "PickPlacePen.json").read_bytes()
    calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=more, progress=False)
    assert (out / "PickPlacePen.json").read_bytes() == finished
    with pytest.raises(ValueError, match="can add episodes, not drop them"):  # the folder keeps its 2 episodes
        calibrate(["PickPlacePen"], work, out, demos_dir=REPO / "demos", config=TINY, protocol=TINY_PROTOCOL,
                  progress=False)

    # `maniladder report` shows a calibration folder
    from maniladder_ms.cli import main

    assert main(["report", str(out)]) == 0
    assert "PickPlacePen" in (out / "report" / "report.html").read_text()


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
    try:
        randomisation_pilot.pick_place_pen_one_side(scale=0.5)
        env = maniladder_ms.make("PickPlacePen", obs_mode="state")
        task = env.unwrapped
        for seed in range(8):
            env.reset(seed=seed)
            pen, tray = task.pen.pose.p[0].tolist(), task.tray.pose.p[0].tolist()
            assert within(pen[0], halved(PickPlacePenEnv.PEN_X)) and within(pen[1], halved(PickPlacePenEnv.PEN_ABS_Y))
            # the tray on the other side
            assert within(tray[0], halved(PickPlacePenEnv.TRAY_X)) and within(-tray[1], halved(PickPlacePenEnv.TRAY_ABS_Y))
            assert abs(actor_yaw(task.tray)) <= PickPlacePenEnv.TRAY_MAX_YAW / 2 + 1e-4
        env.close()
    finally:
        PickPlacePenEnv._initialize_episode = registered


def test_randomisation_pilot_shrinks_every_uniform_layout_draw_about_its_middle():
    sys.path.insert(0, str(REPO / "scripts"))
    import randomisation_pilot

    import maniladder_ms
    from maniladder_ms.tasks.rigid.hang_mug import HangMugEnv

    registered = HangMugEnv._initialize_episode
    try:
        randomisation_pilot.shrink_layout_draws("HangMug", 0.5)
        env = maniladder_ms.make("HangMug", obs_mode="state")
        for seed in range(8):
            env.reset(seed=seed)
            mug, tree = env.unwrapped.mug.pose.p[0].tolist(), env.unwrapped.tree.pose.p[0].tolist()
            assert within(mug[0], halved(HangMugEnv.MUG_X)) and within(mug[1], halved(HangMugEnv.MUG_Y))
            assert within(tree[0], halved(HangMugEnv.TREE_X)) and within(tree[1], halved(HangMugEnv.TREE_Y))
        env.close()
    finally:
        HangMugEnv._initialize_episode = registered
    assert maniladder_ms.make("HangMug", obs_mode="state").unwrapped._initialize_episode.__func__ is registered
