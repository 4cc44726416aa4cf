"""`maniladder demos export --format lerobot`: a committed sample exported as a LeRobot v3.0 dataset and read back
without LeRobot (which does not install beside our pins): pyarrow / pandas for the tables, imageio-ffmpeg for
the video."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

from maniladder_ms.cli import main
from maniladder_ms.demos import DemoFileError, load_demo_json
from maniladder_ms.demos.lerobot import export_lerobot

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "demos/PickPlacePen/trajectory.none.pd_ee_delta_pose.physx_cpu.h5"  # 2 episodes, single Panda
CAM = "front_camera"
VIDEO_KEY = f"observation.images.{CAM}"


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("lerobot") / "ds"
    assert main(["demos", "export", str(DEMO), "--format", "lerobot", "--out", str(out), "--cameras", CAM]) == 0
    return out


def test_export_lerobot_reads_back(exported):
    import imageio_ffmpeg
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = exported
    with h5py.File(DEMO, "r") as h5:
        actions = [h5[f"traj_{i}"]["actions"][()] for i in range(2)]
        robot_states = [h5[f"traj_{i}"]["env_states/articulations/ml_panda"][()] for i in range(2)]
    lengths = [len(a) for a in actions]
    total = sum(lengths)

    info = json.loads((out / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["fps"] == 20 and info["robot_type"] == "ml_panda"
    assert (info["total_episodes"], info["total_frames"], info["total_tasks"]) == (2, total, 1)
    feats = info["features"]
    assert feats[VIDEO_KEY]["dtype"] == "video" and feats[VIDEO_KEY]["shape"] == [128, 128, 3]
    assert feats[VIDEO_KEY]["info"]["video.fps"] == 20 and set(feats) >= {"observation.state", "action", "next.done"}
    assert feats["observation.state"]["shape"] == [9] and feats["observation.state"]["names"][0] == "panda_joint1"
    assert feats["action"]["shape"] == [actions[0].shape[1]]

    table = pq.read_table(out / info["data_path"].format(chunk_index=0, file_index=0))
    schema = table.schema
    assert schema.field("observation.state").type == pa.list_(pa.float32(), 9)
    assert schema.field("action").type == pa.list_(pa.float32(), 7)
    for name, dtype in [("timestamp", pa.float32()), ("frame_index", pa.int64()), ("episode_index", pa.int64()),
                        ("index", pa.int64()), ("task_index", pa.int64()), ("next.done", pa.bool_()),
                        ("next.success", pa.bool_())]:
        assert schema.field(name).type == dtype, name
    assert set(schema.names) == {k for k, f in feats.items() if f["dtype"] != "video"}
    df = table.to_pandas()
    assert df["episode_index"].tolist() == [0] * lengths[0] + [1] * lengths[1]
    assert df["index"].tolist() == list(range(total))
    assert df["frame_index"].tolist() == list(range(lengths[0])) + list(range(lengths[1]))
    assert np.allclose(df["timestamp"], df["frame_index"] / 20)
    assert df["next.done"].sum() == 2 and df["next.done"].iloc[lengths[0] - 1] and df["next.done"].iloc[-1]
    assert df["next.success"].iloc[-1] and (df["task_index"] == 0).all()
    assert np.allclose(np.stack(df["action"]), np.concatenate(actions))
    # proprioception = the recorded robot state: root pose (7) + root velocities (6), then qpos (9), qvel (9)
    qpos = np.concatenate([s[:-1, 13:22] for s in robot_states])
    assert np.allclose(np.stack(df["observation.state"]), qpos, atol=1e-5)

    instruction = load_demo_json(DEMO)["episodes"][0]["instruction"]
    tasks = pd.read_parquet(out / "meta/tasks.parquet")
    assert tasks.index.tolist() == [instruction] and tasks["task_index"].tolist() == [0]
    episodes = pd.read_parquet(out / "meta/episodes/chunk-000/file-000.parquet")
    assert episodes["episode_index"].tolist() == [0, 1] and episodes["length"].tolist() == lengths
    assert episodes["dataset_to_index"].tolist() == [lengths[0], total]
    assert list(episodes["tasks"].iloc[1]) == [instruction]
    assert np.allclose(episodes[f"videos/{VIDEO_KEY}/from_timestamp"], [0, lengths[0] / 20])
    stats = json.loads((out / "meta/stats.json").read_text())
    assert np.shape(stats[VIDEO_KEY]["mean"]) == (3, 1, 1) and stats["action"]["count"] == [total]

    # the video: both episodes back to back, 128 x 128; the first frame of episode 1 is an image, not blank
    reader = imageio_ffmpeg.read_frames(str(out / info["video_path"].format(video_key=VIDEO_KEY, chunk_index=0,
                                                                            file_index=0)))
    meta = next(reader)
    assert meta["size"] == (128, 128) and meta["fps"] == 20
    frames = [np.frombuffer(f, np.uint8).reshape(128, 128, 3) for f in reader]
    assert len(frames) == total
    frame = frames[lengths[0]]
    assert frame.shape == (128, 128, 3) and frame.std() > 10 and len(np.unique(frame.reshape(-1, 3), axis=0)) > 50


LEROBOT_CHECK = """
import sys
from lerobot.datasets.lerobot_dataset import LeRobotDataset
ds = LeRobotDataset("local/maniladder", root=sys.argv[1], video_backend="pyav")
a, b = ds[0], ds[ds.num_frames - 1]
assert ds.fps == 20 and ds.num_episodes == 2 and int(b["episode_index"]) == 1 and b["task"] == a["task"] != ""
assert tuple(a["observation.images.front_camera"].shape) == (3, 128, 128) and tuple(a["observation.state"].shape) == (9,)
print("ok")
"""


@pytest.mark.skipif(not os.environ.get("LEROBOT_PYTHON"), reason="set LEROBOT_PYTHON to a python with lerobot[dataset]")
def test_lerobot_loads_the_export(exported):
    """LeRobot itself (its own venv: it needs Python >= 3.12 and other pins) loads the export and decodes frames."""
    run = subprocess.run([os.environ["LEROBOT_PYTHON"], "-c", LEROBOT_CHECK, str(exported)], capture_output=True,
                         text=True, timeout=600, env={**os.environ, "HF_HUB_OFFLINE": "1"})
    assert run.returncode == 0 and run.stdout.strip().endswith("ok"), run.stderr[-3000:]


def test_export_lerobot_errors(tmp_path, capsys):
    """Refusals before any rendering, then the unknown camera (one env made)."""
    taken = tmp_path / "taken"
    taken.mkdir()
    (taken / "notes.txt").write_text("user data")
    with pytest.raises(FileExistsError, match="not empty.*--overwrite"):
        export_lerobot(DEMO, taken)
    with pytest.raises(FileExistsError, match="not a LeRobot dataset"):
        export_lerobot(DEMO, taken, overwrite=True)
    assert (taken / "notes.txt").read_text() == "user data"

    stray = tmp_path / "stray.h5"
    with h5py.File(stray, "w") as f:
        f["x"] = np.zeros(3)
    with pytest.raises(DemoFileError, match="missing"):
        export_lerobot(stray, tmp_path / "a")
    mixed = tmp_path / "mixed"
    shutil.copytree(DEMO.parent, mixed)  # two control modes: two action spaces
    with pytest.raises(DemoFileError, match="one embodiment and control mode"):
        export_lerobot(mixed, tmp_path / "b")
    for f in mixed.glob("*pd_joint_pos*"):  # the same episodes twice: a demo and a copy under another name
        f.unlink()
    for suffix in (".h5", ".json"):
        shutil.copy(DEMO.with_suffix(suffix), mixed / f"trajectory.rgb.pd_ee_delta_pose.physx_cpu{suffix}")
    with pytest.raises(DemoFileError, match="both hold the PickPlacePen episode of seed 0"):
        export_lerobot(mixed, tmp_path / "b")
    assert main(["demos", "export", str(DEMO), "--format", "lerobot", "--out", str(tmp_path / "c"),
                 "--cameras", f"{CAM},nose_camera"]) == 2
    assert "unknown camera(s) ['nose_camera']; this env has: front_camera, left_camera" in capsys.readouterr().err
    assert not (tmp_path / "c").exists() and not list(tmp_path.glob(".c.partial-*"))


def test_overwrite_replaces_only_a_lerobot_dataset(tmp_path):
    from maniladder_ms.demos.lerobot import _check_out, _replace

    out = tmp_path / "ds"
    (out / "meta").mkdir(parents=True)
    (out / "meta/info.json").write_text("{}")
    (out / "old.txt").write_text("old")
    _check_out(out, overwrite=True)  # a LeRobot dataset: may be replaced
    new = tmp_path / ".ds.partial-x"
    (new / "meta").mkdir(parents=True)
    (new / "meta/info.json").write_text('{"new": 1}')
    _replace(new, out)
    assert json.loads((out / "meta/info.json").read_text()) == {"new": 1} and not (out / "old.txt").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds"]
