"""The `maniladder` command line: list, render, bench, and clear errors."""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from conftest import sampled_tasks

import maniladder_ms

from maniladder_ms.cli import main

REPO = Path(__file__).resolve().parents[1]


def test_list_summary_counts(capsys):
    assert main(["list", "--summary"]) == 0
    out = capsys.readouterr().out
    built = maniladder_ms.default_catalog().filter(implemented=True)
    assert f"implemented / catalog: {len(built)} / 112 tasks" in out
    # each level's first cell (rigid SG): built / catalog tasks of that suite
    cat = maniladder_ms.default_catalog()
    for level in (1, 2):
        suite = cat.filter(suite=f"L{level}-rigid-SG")
        assert f"L{level}     {sum(s.implemented for s in suite)}/{len(suite)}" in out


def test_list_filters_and_json(capsys):
    assert main(["list", "--level", "1", "--suite", "L1-rigid-SG"]) == 0
    out = capsys.readouterr().out
    assert "*  PickPlacePen" in out and "HangMug" in out and "Stack6Blocks" not in out
    assert main(["list", "--skill", "tool_use", "--embodiment", "DG", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert rows and all("tool_use" in r["skills"] and r["embodiment"] == "DG" for r in rows)
    assert main(["list", "--implemented", "--json"]) == 0
    listed = {r["id"] for r in json.loads(capsys.readouterr().out)}
    assert listed == {t.id for t in maniladder_ms.default_catalog().filter(implemented=True)}
    assert {"PickPlacePen", "Stack6Blocks", "HangMug", "HandoverCube"} <= listed


def test_levels_shown_say_whether_they_are_measured(capsys, tmp_path, monkeypatch):
    """No current-protocol result committed: every level is a design target, and list/show say so; a committed
    current final result of the task as built makes its level measured (a development run does not)."""
    from maniladder_ms import levels, provenance
    from maniladder_ms.policy.flow import PROTOCOL_VERSION

    assert main(["list", "--suite", "L1-rigid-SG"]) == 0
    out = capsys.readouterr().out
    assert "L1 target" in out and "design targets" in out and "measured" not in out.split("design targets")[0]
    assert main(["show", "PickPlacePen"]) == 0 and "design target" in capsys.readouterr().out
    result = {"task": "PickPlacePen", "measured_level": 1, "measured_level_text": "L1", "success": 0.72,
              "protocol": PROTOCOL_VERSION, "task_hash": provenance.task_hash("PickPlacePen")}
    read = levels.measured_results.__wrapped__
    monkeypatch.setattr(levels, "measured_results", lambda folder=tmp_path: read(folder))
    (tmp_path / "PickPlacePen.json").write_text(json.dumps({**result, "purpose": "development"}))
    assert main(["list", "--suite", "L1-rigid-SG"]) == 0  # a development run does not place the task
    out = capsys.readouterr().out
    assert "measured" not in out.split("design targets")[0] and "PickPlacePen" in out
    (tmp_path / "PickPlacePen.json").write_text(json.dumps({**result, "purpose": "final"}))
    assert main(["list", "--suite", "L1-rigid-SG"]) == 0
    out = capsys.readouterr().out
    assert f"L1 measured {PROTOCOL_VERSION} (72%, L1)" in out and "1 of" in out and "L1 target" in out


def test_show_points_at_the_row_the_class_and_the_solver(capsys):
    assert main(["show", "PickPlacePen"]) == 0
    out = capsys.readouterr().out
    assert "maniladder_ms/tasks/rigid/pick_place_pen.py:" in out and "solve_pick_place_pen" in out
    assert "maniladder_ms/solvers/rigid/pick_place_pen.py:" in out  # the solver tree mirrors the task tree
    assert "margin" in out and "(2 cm margin)" in out
    from maniladder_ms.layout import format_breadth, object_breadths

    layout = format_breadth(object_breadths(dict(maniladder_ms.default_catalog().get("PickPlacePen").params)))
    assert "layout" in out and layout in out and "cm2" in layout  # the row's layout breadth
    line = int(out.split("task_catalog.yaml:")[1].split()[0])
    catalog = (REPO / "maniladder_ms/data/task_catalog.yaml").read_text().splitlines()
    assert catalog[line - 1] == "- id: PickPlacePen"
    assert main(["show", "TieKnotHands"]) == 0 and "not built yet" in capsys.readouterr().out
    assert main(["show", "PickPlacePencil"]) == 2


def test_list_and_show_give_the_language_instructions(capsys):
    pen = maniladder_ms.default_catalog().get("PickPlacePen")
    assert main(["list"]) == 0
    assert pen.instruction not in capsys.readouterr().out  # the default table stays narrow
    assert main(["list", "--level", "1", "--instructions"]) == 0
    out = capsys.readouterr().out
    assert all(t.instruction in out for t in maniladder_ms.default_catalog().filter(level=1))
    assert main(["list", "--level", "1", "--json"]) == 0
    row = next(r for r in json.loads(capsys.readouterr().out) if r["id"] == "PickPlacePen")
    assert row["instruction"] == pen.instruction and row["paraphrases"] == list(pen.paraphrases)
    assert main(["show", "PickPlacePen"]) == 0
    out = capsys.readouterr().out
    assert any(line.startswith("instruction ") and line.endswith(pen.instruction) for line in out.splitlines())
    assert all(f"paraphrase {i}" in out and p in out for i, p in enumerate(pen.paraphrases, 1))


def test_unknown_task_exits_2_with_message(capsys):
    assert main(["render", "PickPlacePencil"]) == 2
    assert "unknown ManiLadder task 'PickPlacePencil'" in capsys.readouterr().err
    assert main(["list", "--suite", "L9-rigid-SG"]) == 2


def _all_parsers(parser, prog="maniladder"):
    yield prog, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _all_parsers(sub, f"{prog} {name}")


def test_every_help_text_renders_its_percent_signs_once():
    """argparse %-formats help strings but not descriptions: '%%' belongs in the first, '%' in the second."""
    from maniladder_ms.cli import build_parser

    for prog, parser in _all_parsers(build_parser()):
        text = parser.format_help()  # a lone '%' in a help string raises here
        assert "%%" not in text, f"`{prog} --help` prints a doubled percent sign"


def test_render_writes_all_cameras(tmp_path, capsys):
    out = tmp_path / "pen.png"
    assert main(["render", "PickPlacePen", "--seed", "1", "--out", str(out), "--size", "128"]) == 0
    img = np.asarray(Image.open(out))
    assert img.shape[1] == 4 * 128  # front, left, top, wrist side by side
    panels = [img[22:150, i * 128:(i + 1) * 128].astype(float) for i in range(4)]
    assert all(p.std() > 10 for p in panels)


def test_render_solved_shows_the_solver_s_last_step(tmp_path, capsys):
    reset, solved = tmp_path / "reset.png", tmp_path / "solved.png"
    for out, extra in ((reset, []), (solved, ["--solved"])):
        assert main(["render", "PickPlacePen", "--seed", "100", "--out", str(out), "--size", "96", *extra]) == 0
    a, b = (np.asarray(Image.open(p)).astype(float) for p in (reset, solved))
    assert a.shape == b.shape
    # the top camera (third panel) sees the pen moved to its goal and the arm elsewhere
    assert np.abs(a[22:118, 192:288] - b[22:118, 192:288]).mean() > 2
    assert main(["render", "--robot", "ml_panda", "--solved"]) == 2
    assert "--solved shows a task" in capsys.readouterr().err


def test_bench_prints_ratios(capsys):
    assert main(["bench", "PickPlacePen", "--steps", "20"]) == 0
    out = capsys.readouterr().out
    line = next(l for l in out.splitlines() if l.startswith("ManiLadder-PickPlacePen-v1"))
    _, rate, ratio, beside = line.split()
    assert float(ratio) == pytest.approx(float(rate) / float(beside), abs=0.01 + 0.02 * float(ratio))


def test_bench_compares_each_target_with_the_reference_runs_beside_it(monkeypatch):
    """A load that drifts along the list: each target's ratio is to the reference runs just before and after it."""
    import maniladder_ms.bench as bench_module

    reference_rates = iter([100.0, 80.0, 40.0])
    monkeypatch.setattr(bench_module, "steps_per_second",
                        lambda env_id, *a, **k: next(reference_rates) if env_id == bench_module.REFERENCE_ENV else 30.0)
    rows = bench_module.bench(["ManiLadder-A-v1", "ManiLadder-B-v1"], steps=1)
    assert [r["env_id"] for r in rows] == [bench_module.REFERENCE_ENV, "ManiLadder-A-v1", "ManiLadder-B-v1"]
    assert rows[0]["steps_per_s"] == pytest.approx(220 / 3)
    assert [r["ratio"] for r in rows[1:]] == pytest.approx([30 / 90, 30 / 60])


def test_bench_records_rows_and_updates_a_table_only_when_asked(monkeypatch, tmp_path, capsys):
    import json

    import maniladder_ms.bench as bench_module

    rates = iter([100.0, 50.0, 100.0, 25.0, 100.0])
    monkeypatch.setattr(bench_module, "steps_per_second", lambda env_id, *a, **k: next(rates))
    table = tmp_path / "bench.json"
    assert main(["bench", "PickPlacePen", "HangMug", "--steps", "1", "--out", str(table)]) == 0
    rows = json.loads(table.read_text())["rows"]
    assert {k: v["ratio"] for k, v in rows.items()} == {"ManiLadder-PickPlacePen-v1": 0.5, "ManiLadder-HangMug-v1": 0.25}
    assert rows["ManiLadder-HangMug-v1"]["steps"] == 1 and rows["ManiLadder-HangMug-v1"]["obs_mode"] == "state"
    # an existing table is refused before anything is measured, and kept as it was
    before = table.read_text()
    assert main(["bench", "HangMug", "--steps", "1", "--out", str(table)]) == 2
    assert "--update" in capsys.readouterr().err and table.read_text() == before
    rates = iter([100.0, 80.0, 100.0])
    monkeypatch.setattr(bench_module, "steps_per_second", lambda env_id, *a, **k: next(rates))
    assert main(["bench", "HangMug", "--steps", "1", "--out", str(table), "--update"]) == 0
    rows = json.loads(table.read_text())["rows"]
    assert {k: v["ratio"] for k, v in rows.items()} == {"ManiLadder-HangMug-v1": 0.8, "ManiLadder-PickPlacePen-v1": 0.5}


def test_bench_rgb_with_declared_cameras_and_chunks(capsys):
    assert main(["bench", "PickPlacePen", "--steps", "8", "--obs-mode", "rgb",
                 "--cameras", "front_camera,left_camera,top_camera", "--render-every", "4"]) == 0
    line = next(l for l in capsys.readouterr().out.splitlines() if l.startswith("ManiLadder-PickPlacePen-v1"))
    assert float(line.split()[2]) > 0


def test_render_agent_and_showcase(tmp_path, capsys):
    out = tmp_path / "leap.png"
    assert main(["render", "--robot", "ml_panda_leap", "--out", str(out), "--size", "96"]) == 0
    assert np.asarray(Image.open(out)).shape[1] == 5 * 96  # front, left, top, wrist + the hand close-up
    out = tmp_path / "towel.png"
    assert main(["render", "--scene", "towel", "--out", str(out), "--size", "96"]) == 0
    assert out.exists()


def test_render_and_bench_refuse_bad_targets(capsys):
    assert main(["render", "--robot", "ml_panda_octopus"]) == 2
    assert "unknown robot 'ml_panda_octopus'" in capsys.readouterr().err
    assert main(["render", "PickPlacePen", "--scene", "rope"]) == 2
    assert "exactly one of" in capsys.readouterr().err
    assert main(["bench", "--scene", "jelly"]) == 2
    assert "unknown scene 'jelly'" in capsys.readouterr().err
    assert main(["render", "PickPlacePen", "--visual-seed", "1"]) == 2
    assert "add --dr" in capsys.readouterr().err


def test_render_dr_visual_seed_changes_the_look(tmp_path, capsys):
    images = []
    for k in (0, 1):
        out = tmp_path / f"look{k}.png"
        assert main(["render", "PickPlacePen", "--dr", "--seed", "3", "--visual-seed", str(k), "--out", str(out),
                     "--size", "64"]) == 0
        images.append(np.asarray(Image.open(out).convert("RGB")).astype(float)[22:86])
    assert np.abs(images[0] - images[1]).mean() > 5


def test_bench_agents_and_showcases(capsys):
    assert main(["bench", "--robot", "ml_dual_panda_leap", "--scene", "rope", "--steps", "10"]) == 0
    out = capsys.readouterr().out
    assert "ManiLadder-AgentGallery-v1 [ml_dual_panda_leap]" in out and "ManiLadderShowcase-Rope-v1" in out


def test_console_script_is_installed():
    exe = Path(sys.executable).with_name("maniladder")
    result = subprocess.run([str(exe), "list", "--level", "4", "--json"], capture_output=True, text=True, check=True)
    assert len(json.loads(result.stdout)) == 28


def test_wheel_install_carries_the_catalog(tmp_path):
    """A non-editable wheel has the package data; imported from the wheel, the catalog loads."""
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(tmp_path / "dist"), str(REPO)], check=True)
    wheel = next((tmp_path / "dist").glob("maniladder_ms-*.whl"))
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target), str(wheel)],
                   check=True)
    code = "import maniladder_ms; print(maniladder_ms.__file__); print(len(maniladder_ms.default_catalog()))"
    env = dict(os.environ, PYTHONPATH=str(target))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=tmp_path, env=env).stdout.split()
    assert out[0].startswith(str(target)) and out[1] == "112"
    assert (target / "maniladder_ms" / "data" / "agents" / "ml_panda_leap.urdf").is_file()
    assert (target / "bin" / "maniladder").exists()


BUILT = [t.id for t in maniladder_ms.default_catalog().filter(implemented=True)]


@pytest.mark.parametrize("task", sampled_tasks(BUILT, k=2))
def test_quickstart_records_a_video_per_task_and_seed(task, tmp_path):
    """The README's quickstart, as printed, on any built task: its video is recorded in the control mode the
    task's solver drives and named after the task and seed; a second run does not overwrite it unasked."""
    cmd = [sys.executable, str(REPO / "examples" / "quickstart.py"), task, "--episodes", "1", "--video", str(tmp_path)]
    run = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    video = tmp_path / f"{task}_seed0.mp4"
    assert video.stat().st_size > 0 and [p.name for p in tmp_path.iterdir()] == [video.name]
    again = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True)
    assert again.returncode != 0 and "pass --overwrite" in again.stderr
