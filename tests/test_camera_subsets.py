"""Camera subsets as part of the evaluation protocol (`maniladder eval --cameras ...`): what the policy sees, the
manifest's identity key (older folders count as all cameras), clear errors, and the report's refusal to mix."""

import dataclasses
import json

import pytest

import maniladder_ms
from maniladder_ms.evaluation import PROTOCOL_VERSION, eval_seed
from maniladder_ms.evaluation.cli import main as eval_main
from maniladder_ms.evaluation.policies import PolicyError
from maniladder_ms.evaluation.report import write_report
from maniladder_ms.evaluation.results import ResultsError, open_run, read_episodes
from maniladder_ms.evaluation.runner import camera_subset, evaluate

PEN = "PickPlacePen"
PEN_CAMERAS = "front_camera, left_camera, top_camera, hand_camera"

SEEING = '''
import json
import numpy as np

class Seeing:
    """Zero actions in chunks of 5; writes down the cameras (and image shapes) of every call."""
    image_size = 32

    def __call__(self, obs, spec):
        with open(__file__ + ".seen", "a") as f:
            f.write(json.dumps(sorted(obs["sensor_data"])) + "\\n")
        return np.zeros((5, 8), dtype=np.float32)

class Looking(Seeing):
    cameras = ("left_camera",)
'''


@pytest.fixture
def short_pen(monkeypatch):
    cat = maniladder_ms.default_catalog()
    monkeypatch.setitem(cat._by_id, PEN, dataclasses.replace(cat.get(PEN), horizon=5))


@pytest.fixture
def seeing(tmp_path):
    path = tmp_path / "seeing.py"
    path.write_text(SEEING)
    return path


def test_camera_subset_parsing():
    assert camera_subset(None) is None and camera_subset("all") is None and camera_subset("") is None
    assert camera_subset("top_camera, front_camera,top_camera") == ("front_camera", "top_camera")
    assert camera_subset(["hand_camera"]) == ("hand_camera",)
    with pytest.raises(ValueError, match="names no camera"):
        camera_subset(" , ")


def test_the_policy_sees_the_subset_and_the_run_keeps_it(short_pen, seeing, tmp_path):
    out = tmp_path / "run"
    evaluate(f"{seeing}:Seeing", out, tasks=[PEN], episodes=1, cameras="top_camera,front_camera", progress=False)
    seen = [json.loads(x) for x in (tmp_path / "seeing.py.seen").read_text().splitlines()]
    assert seen == [["front_camera", "top_camera"]]  # one call (horizon 5, chunk 5), two cameras of the four
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["cameras"] == ["front_camera", "top_camera"]
    assert manifest["task_env"][PEN]["cameras"] == ["front_camera", "top_camera"]
    # a resume under another subset (or all cameras) is refused; the same subset, spelled otherwise, resumes
    for other, shown in [(None, "'all' now"), ("front_camera", r"\['front_camera'\] now")]:
        with pytest.raises(ResultsError, match=rf"another run \(cameras \['front_camera', 'top_camera'\] there vs {shown}"):
            evaluate(f"{seeing}:Seeing", out, tasks=[PEN], episodes=2, cameras=other, progress=False)
    assert len(read_episodes(out)) == 1
    evaluate(f"{seeing}:Seeing", out, tasks=[PEN], episodes=2, cameras=" front_camera,top_camera", progress=False)
    assert [r["seed"] for r in read_episodes(out)] == [eval_seed(0, 0), eval_seed(0, 1)]


def test_unknown_cameras_and_imageless_policies_are_clear_errors(short_pen, seeing, tmp_path, capsys):
    out = tmp_path / "run"
    with pytest.raises(ValueError, match=rf"task {PEN}: unknown camera\(s\) \['front_camra'\]; this env has: {PEN_CAMERAS}"):
        evaluate(f"{seeing}:Seeing", out, tasks=[PEN], episodes=1, cameras="front_camra", progress=False)
    assert not out.exists()  # refused before the results folder is written: the corrected command starts clean
    with pytest.raises(PolicyError, match=rf"task {PEN}: the policy looks at left_camera, outside --cameras front_camera"):
        evaluate(f"{seeing}:Looking", out, tasks=[PEN], episodes=1, cameras="front_camera", progress=False)
    assert eval_main(["eval", "--policy", "random", "--tasks", PEN, "--cameras", "front_camera", "--out", str(out)]) == 2
    assert "obs mode 'none', which has none" in capsys.readouterr().err
    assert not out.exists()


def test_results_from_before_cameras_count_as_all(tmp_path):
    old = {"protocol_version": PROTOCOL_VERSION, "policy": "p:P", "obs_mode": "rgb", "seed": 0, "tasks": [PEN]}
    open_run(tmp_path, old)  # a manifest written without the key
    assert open_run(tmp_path, dict(old, cameras="all"))["policy"] == "p:P"
    with pytest.raises(ResultsError, match=r"cameras 'all' there vs \['front_camera'\] now"):
        open_run(tmp_path, dict(old, cameras=["front_camera"]))


def _fake_run(path, policy, cameras=None, n=4):
    path.mkdir(parents=True)
    manifest = {"protocol_version": PROTOCOL_VERSION, "policy": policy, "obs_mode": "rgb", "seed": 0, "episodes": n,
                "tasks": [PEN], "skipped": {}}
    if cameras is not None:
        manifest["cameras"] = cameras
    (path / "manifest.json").write_text(json.dumps(manifest))
    with open(path / "episodes.jsonl", "w") as f:
        for k in range(n):
            f.write(json.dumps(dict(task=PEN, episode=k, seed=eval_seed(0, k), success=k < 2, steps=10, wall_s=0.1)) + "\n")


def test_report_shows_the_subsets_and_refuses_to_mix_them(tmp_path, capsys):
    _fake_run(tmp_path / "old", "a:Old")  # from before the key: all cameras
    _fake_run(tmp_path / "all", "b:All", cameras="all")
    _fake_run(tmp_path / "front", "c:Front", cameras=["front_camera"])
    page = write_report([tmp_path / "old", tmp_path / "all"], out=tmp_path / "rep").read_text()
    assert "<th>cameras</th>" in page and page.count("<td>all</td>") == 2
    with pytest.raises(ResultsError, match=r"different camera subsets \(a-Old .*: all; b-All .*: all; c-Front .*: front_camera\)"
                                           r".*--mixed-cameras"):
        write_report([tmp_path / "old", tmp_path / "all", tmp_path / "front"], out=tmp_path / "rep2")
    assert not (tmp_path / "rep2").exists()
    assert eval_main(["report", str(tmp_path / "all"), str(tmp_path / "front"), "--out", str(tmp_path / "rep3")]) == 2
    assert "different camera subsets" in capsys.readouterr().err
    assert eval_main(["report", str(tmp_path / "all"), str(tmp_path / "front"), "--out", str(tmp_path / "rep3"),
                      "--mixed-cameras"]) == 0
    page = (tmp_path / "rep3" / "report.html").read_text()
    assert "<td>front_camera</td>" in page and "saw different camera subsets" in page
