"""`maniladder demos export --format lerobot`: ManiLadder demo files as one LeRobot v3.0 dataset.

Layout (LeRobot's `CODEBASE_VERSION` v3.0: many episodes a file, episodes located through meta/episodes):

    meta/info.json  meta/stats.json  meta/tasks.parquet  meta/episodes/chunk-000/file-000.parquet
    meta/maniladder.json                                  (provenance: source files, seeds; LeRobot ignores it)
    data/chunk-000/file-000.parquet                       (every frame of every episode)
    videos/observation.images.<camera>/chunk-000/file-000.mp4   (episodes back to back; from/to_timestamp)

A frame t is the obs before action t: the cameras' images and the robot's joint positions
(`observation.state`) and velocities (`observation.velocity`), rendered by restoring the recorded env state
t (`demos.frames`; state-only demos need no obs recorded), with `action` t in the recorded control mode,
`next.reward` / `next.success` after it and `next.done` on the episode's last frame. The task string of an
episode is its recorded language instruction (`tasks.parquet` maps each distinct one to its `task_index`).
Images are the cameras' native 128 x 128; `fps` (default 20, the control frequency of every ManiLadder
task) sets the timestamps and the videos' rate.

ManiSkill 3.0.1's `mani_skill.trajectory.convert_to_lerobot` is not reused: it reads images recorded in the
h5 (ours are state-only), letterboxes to 640x480 at 30 fps with OpenCV's mp4v, writes one video file an
episode and keeps every frame of the dataset in memory for its stats. This writer streams episode by episode.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from maniladder_ms.envs.base import CAMERA_SIZE

from .files import DemoFileError, load_demo_json, open_demo_h5, replay_env_kwargs

CODEBASE_VERSION = "v3.0"
DEFAULT_FPS = 20
CHUNKS_SIZE = 1000  # LeRobot's defaults, recorded in info.json (this writer puts everything in file 000)
DATA_FILE_SIZE_IN_MB = 100
VIDEO_FILE_SIZE_IN_MB = 200
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-000/file-000.parquet"
VCODECS = {"libsvtav1": "av1", "libx264": "h264"}  # ffmpeg encoder -> codec name in info.json
IMAGE_KEY = "observation.images.{}"


@dataclass
class ExportResult:
    out: Path
    episodes: int
    frames: int
    cameras: tuple
    tasks: list = field(default_factory=list)


def demo_files(path: Path) -> list[Path]:
    """The demo .h5 files of `path`: the file itself, or every .h5 below a folder (sorted; hidden folders such
    as generation's `.parts/` left out)."""
    path = Path(path)
    if path.is_dir():
        files = sorted(p for p in path.rglob("*.h5") if not any(d.startswith(".") for d in p.relative_to(path).parts))
        if not files:
            raise DemoFileError(f"{path}: no demo .h5 files in this folder")
        return files
    if path.suffix != ".h5":
        raise DemoFileError(f"{path}: not a demo .h5 file")
    if not path.exists():
        raise DemoFileError(f"{path}: no such file")
    return [path]


def _check_out(out: Path, overwrite: bool) -> None:
    if not out.exists():
        return
    if not out.is_dir():
        raise FileExistsError(f"{out}: exists and is not a folder")
    if any(out.iterdir()):
        if not overwrite:
            raise FileExistsError(f"{out}: exists and is not empty (pass --overwrite to replace a LeRobot dataset there)")
        if not (out / "meta" / "info.json").exists():
            raise FileExistsError(f"{out}: not replacing a folder that is not a LeRobot dataset (no meta/info.json); "
                                  "choose another --out")


def _check_files(files: Sequence[Path]) -> list[dict]:
    """Every file's json, checked to be ManiLadder demos that share one action space."""
    metas = [load_demo_json(f) for f in files]
    for f in files:  # the h5 opens (a json beside a broken h5 is caught before any rendering)
        open_demo_h5(f).close()
    kinds = {(m["task_spec"].embodiment, replay_env_kwargs(m).get("control_mode"), replay_env_kwargs(m).get("robot_uids"))
             for m in metas}
    if len(kinds) > 1:
        listed = "\n  ".join(f"{f}: {m['task_spec'].embodiment}, {replay_env_kwargs(m).get('control_mode')}"
                             for f, m in zip(files, metas))
        raise DemoFileError("one dataset needs one embodiment and control mode (one action space); these files "
                            f"differ, export them separately:\n  {listed}")
    seen: dict = {}
    for f, m in zip(files, metas):  # e.g. a demo and its replay into another obs mode, side by side
        for ep in m["episodes"]:
            key = (m["task_spec"].id, ep["episode_seed"])
            if seen.setdefault(key, f) != f:
                raise DemoFileError(f"{f} and {seen[key]} both hold the {key[0]} episode of seed {key[1]}: "
                                    "export one of them")
    return metas


def _vector_stats(x: np.ndarray) -> dict:
    x = np.asarray(x, np.float64).reshape(len(x), -1)
    return {"min": x.min(0), "max": x.max(0), "mean": x.mean(0), "std": x.std(0), "count": np.array([len(x)])}


def _image_stats(images: np.ndarray) -> dict:
    """(F, H, W, 3) uint8 -> per channel stats of values in [0, 1], shaped (3, 1, 1) as LeRobot's."""
    x = images.reshape(-1, 3).astype(np.float64) / 255.0
    s = {"min": x.min(0), "max": x.max(0), "mean": x.mean(0), "std": x.std(0)}
    return {**{k: v.reshape(3, 1, 1) for k, v in s.items()}, "count": np.array([len(images)])}


def _aggregate(stats: list[dict]) -> dict:
    """Episode stats -> dataset stats (count-weighted mean, pooled variance), as LeRobot aggregates them."""
    counts = np.array([s["count"][0] for s in stats], np.float64)
    w = (counts / counts.sum()).reshape(-1, *[1] * np.ndim(stats[0]["mean"]))
    means = np.stack([s["mean"] for s in stats])
    mean = (w * means).sum(0)
    var = (w * (np.stack([s["std"] for s in stats]) ** 2 + (means - mean) ** 2)).sum(0)
    return {"min": np.min([s["min"] for s in stats], 0), "max": np.max([s["max"] for s in stats], 0),
            "mean": mean, "std": np.sqrt(var), "count": np.array([int(counts.sum())])}


def _jsonable(stats: dict) -> dict:
    return {k: {s: np.asarray(v).tolist() for s, v in d.items()} for k, d in stats.items()}


class _Video:
    """One camera's mp4: RGB frames piped to imageio-ffmpeg's ffmpeg, LeRobot's settings (yuv420p, GOP 2)."""

    def __init__(self, path: Path, size: int, fps: int, vcodec: str):
        import imageio_ffmpeg

        path.parent.mkdir(parents=True, exist_ok=True)
        quality = ["-crf", "30", "-preset", "12"] if vcodec == "libsvtav1" else ["-crf", "23"]
        self._writer = imageio_ffmpeg.write_frames(
            str(path), (size, size), fps=fps, codec=vcodec, pix_fmt_in="rgb24", pix_fmt_out="yuv420p",
            quality=None, macro_block_size=1, ffmpeg_log_level="error", output_params=["-g", "2", *quality])
        before = os.environ.get("SVT_LOG")
        os.environ["SVT_LOG"] = "1"  # SVT-AV1's own log (not ffmpeg's): errors only; ffmpeg starts on the first send
        try:
            self._writer.send(None)
        finally:
            os.environ.pop("SVT_LOG") if before is None else os.environ.__setitem__("SVT_LOG", before)

    def write(self, frames: np.ndarray) -> None:
        for frame in frames:
            self._writer.send(np.ascontiguousarray(frame))

    def close(self) -> None:
        self._writer.close()


def _features(cameras, joint_names, action_dim: int, size: int, fps: int, vcodec: str) -> dict:
    vec = lambda dtype, names: {"dtype": dtype, "shape": [len(names)], "names": list(names)}  # noqa: E731
    scalar = lambda dtype: {"dtype": dtype, "shape": [1], "names": None}  # noqa: E731
    feats = {IMAGE_KEY.format(cam): {
        "dtype": "video", "shape": [size, size, 3], "names": ["height", "width", "channels"],
        "info": {"video.height": size, "video.width": size, "video.codec": VCODECS[vcodec], "video.pix_fmt": "yuv420p",
                 "video.is_depth_map": False, "video.fps": fps, "video.channels": 3, "has_audio": False},
    } for cam in cameras}
    feats.update({
        "observation.state": vec("float32", joint_names),
        "observation.velocity": vec("float32", joint_names),
        "action": vec("float32", [f"action_{i}" for i in range(action_dim)]),
        "next.reward": scalar("float32"), "next.done": scalar("bool"), "next.success": scalar("bool"),
        "timestamp": scalar("float32"), "frame_index": scalar("int64"), "episode_index": scalar("int64"),
        "index": scalar("int64"), "task_index": scalar("int64"),
    })
    return feats


def _episode_columns(e, rewards, success, episode_index: int, start: int, task_index: int, fps: int) -> dict:
    """The data columns of one episode (`EpisodeFrames` e), as numpy arrays in LeRobot's dtypes."""
    n = len(e.actions)
    return {
        "observation.state": e.qpos, "observation.velocity": e.qvel, "action": e.actions,
        "next.reward": np.asarray(rewards, np.float32), "next.done": np.arange(n) == n - 1,
        "next.success": np.asarray(success, bool), "timestamp": np.arange(n, dtype=np.float32) / fps,
        "frame_index": np.arange(n, dtype=np.int64), "episode_index": np.full(n, episode_index, np.int64),
        "index": np.arange(start, start + n, dtype=np.int64), "task_index": np.full(n, task_index, np.int64),
    }


def _table(columns: dict):
    """Vectors as fixed-size lists (what LeRobot's `datasets.Sequence(length=...)` features store)."""
    import pyarrow as pa

    return pa.table({k: pa.FixedSizeListArray.from_arrays(pa.array(v.astype(np.float32).ravel()), v.shape[1])
                     if v.ndim == 2 else pa.array(v) for k, v in columns.items()})


def _episode_row(episode_index: int, task: str, start: int, n: int, cameras, fps: int, stats: dict) -> dict:
    """The episode's row of meta/episodes: where its frames lie in the data and video files, and its stats."""
    t0 = start / fps  # the episode's start in the videos (episodes back to back)
    row = {"episode_index": episode_index, "tasks": [task], "length": n, "data/chunk_index": 0,
           "data/file_index": 0, "dataset_from_index": start, "dataset_to_index": start + n}
    for key in map(IMAGE_KEY.format, cameras):
        row.update({f"videos/{key}/chunk_index": 0, f"videos/{key}/file_index": 0,
                    f"videos/{key}/from_timestamp": t0, f"videos/{key}/to_timestamp": t0 + n / fps})
    row.update({f"stats/{k}/{s}": np.asarray(v).tolist() for k, d in stats.items() for s, v in d.items()})
    return {**row, "meta/episodes/chunk_index": 0, "meta/episodes/file_index": 0}


def export_lerobot(path, out, cameras: Optional[Sequence[str]] = None, fps: int = DEFAULT_FPS,
                   overwrite: bool = False, vcodec: str = "libsvtav1", progress: bool = True) -> ExportResult:
    """Write the demos of `path` (a demo .h5, or a folder of them: one embodiment and control mode) as a LeRobot
    v3.0 dataset in `out`. `cameras`: camera uids (default all the task's). The dataset is written beside
    `out` and moved there when complete; an existing `out` is refused unless `overwrite` and it is a LeRobot
    dataset (meta/info.json)."""
    import pandas as pd
    import pyarrow.parquet as pq
    from tqdm import tqdm

    from .frames import replay_frames, robot_joint_names

    if fps <= 0:
        raise ValueError(f"fps must be positive, not {fps}")
    if vcodec not in VCODECS:
        raise ValueError(f"vcodec {vcodec!r}: one of {', '.join(VCODECS)}")
    out = Path(out)
    _check_out(out, overwrite)
    files = demo_files(Path(path))
    metas = _check_files(files)
    size = CAMERA_SIZE
    out.parent.mkdir(parents=True, exist_ok=True)
    tasks: dict[str, int] = {}
    episodes, ep_stats, provenance = [], [], []
    state = {"cameras": None if cameras is None else tuple(cameras), "joints": None, "robot": None, "videos": {}}
    writer, index = None, 0
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=out.parent))
    try:
        bar = tqdm(total=sum(len(m["episodes"]) for m in metas), desc="export lerobot", unit="episode",
                   disable=not progress)

        def on_env(base, cams, f):  # each file's env: the dataset keeps one camera set and one robot
            if state["cameras"] not in (None, cams):
                raise DemoFileError(f"{f}: its task has cameras {cams}, the dataset so far {state['cameras']}")
            joints = robot_joint_names(base)
            if state["joints"] not in (None, joints):
                raise DemoFileError(f"{f}: its robot's joints differ from the dataset's so far")
            state["cameras"], state["joints"], state["robot"] = cams, joints, str(base.robot_uids)

        for f, meta in zip(files, metas):
            with open_demo_h5(f) as h5:
                for e in replay_frames(f, state["cameras"], size, stride=1,
                                       on_env=lambda base, cams, f=f: on_env(base, cams, f)):
                    cams, ep = state["cameras"], e.ep
                    group = h5[f"traj_{ep['episode_id']}"]
                    n = len(e.actions)
                    rewards = group["rewards"][()] if "rewards" in group else np.zeros(n)
                    success = group["success"][()] if "success" in group else np.zeros(n, bool)
                    task_index = tasks.setdefault(ep["instruction"], len(tasks))
                    episode_index = len(episodes)
                    columns = _episode_columns(e, rewards, success, episode_index, index, task_index, fps)
                    table = _table(columns)
                    if writer is None:  # the first episode fixes the features
                        features = _features(cams, state["joints"], e.actions.shape[1], size, fps, vcodec)
                        for cam in cams:
                            key = IMAGE_KEY.format(cam)
                            state["videos"][cam] = _Video(
                                tmp / VIDEO_PATH.format(video_key=key, chunk_index=0, file_index=0), size, fps, vcodec)
                        data_path = tmp / DATA_PATH.format(chunk_index=0, file_index=0)
                        data_path.parent.mkdir(parents=True)
                        writer = pq.ParquetWriter(data_path, table.schema)
                    elif table.schema != writer.schema:
                        raise DemoFileError(f"{f}: episode {ep['episode_id']} has other shapes than the dataset's "
                                            f"({table.schema} vs {writer.schema})")
                    writer.write_table(table)
                    stats = {k: _vector_stats(v) for k, v in columns.items()}
                    for c, cam in enumerate(cams):
                        state["videos"][cam].write(e.images[:, c])
                        stats[IMAGE_KEY.format(cam)] = _image_stats(e.images[:, c])
                    episodes.append(_episode_row(episode_index, ep["instruction"], index, n, cams, fps, stats))
                    ep_stats.append(stats)
                    provenance.append({"episode_index": episode_index, "file": str(f), "task": meta["task_spec"].id,
                                       "episode_id": ep["episode_id"], "episode_seed": ep["episode_seed"]})
                    index += n
                    bar.update(1)
        bar.close()
        if writer is None:
            raise DemoFileError(f"{path}: the demo files hold no episodes")
        writer.close()
        for video in state["videos"].values():
            video.close()

        (tmp / EPISODES_PATH).parent.mkdir(parents=True)
        pd.DataFrame(episodes).to_parquet(tmp / EPISODES_PATH, index=False)
        pd.DataFrame({"task_index": list(tasks.values())}, index=pd.Index(list(tasks), name="task")).to_parquet(
            tmp / "meta" / "tasks.parquet")
        stats = {k: _aggregate([s[k] for s in ep_stats]) for k in ep_stats[0]}
        (tmp / "meta" / "stats.json").write_text(json.dumps(_jsonable(stats), indent=2))
        specs = {m["task_spec"].id: m for m in metas}
        mb = lambda sub: int(sum(p.stat().st_size for p in (tmp / sub).rglob("*")) / 2**20)  # noqa: E731
        info = {
            "codebase_version": CODEBASE_VERSION,
            "robot_type": state["robot"],
            "total_episodes": len(episodes), "total_frames": index, "total_tasks": len(tasks),
            "chunks_size": CHUNKS_SIZE, "data_files_size_in_mb": max(DATA_FILE_SIZE_IN_MB, mb("data")),
            "video_files_size_in_mb": max(VIDEO_FILE_SIZE_IN_MB, mb("videos")), "fps": fps,
            "splits": {"train": f"0:{len(episodes)}"}, "data_path": DATA_PATH, "video_path": VIDEO_PATH,
            "features": features,
        }
        (tmp / "meta" / "info.json").write_text(json.dumps(info, indent=2))
        (tmp / "meta" / "maniladder.json").write_text(json.dumps({
            "tasks": sorted(specs), "control_mode": replay_env_kwargs(metas[0]).get("control_mode"),
            "sources": [str(f) for f in files], "episodes": provenance}, indent=2))
        _replace(tmp, out)
    except BaseException:
        if writer is not None:
            writer.close()
        for video in state["videos"].values():
            try:
                video.close()
            except Exception:  # noqa: BLE001 - the original error matters
                pass
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return ExportResult(out, len(episodes), index, tuple(state["cameras"]), list(tasks))


def _replace(tmp: Path, out: Path) -> None:
    """Move the finished dataset to `out` (after `_check_out`: missing, empty, or a LeRobot dataset)."""
    old = None
    if out.exists():
        old = out.with_name(f".{out.name}.old-{tmp.name.rsplit('-', 1)[-1]}")
        out.rename(old)
    tmp.rename(out)
    if old is not None:
        shutil.rmtree(old)
