"""Episode videos of an evaluation (`maniladder eval --videos K`): the first K episodes of each task as MP4s, so a
failure can be watched instead of guessed from its record.

Each frame is the task's render camera (512 x 512, every control step) over a strip of the images the policy last
saw (its cameras side by side, refreshed at each observation that rendered them: at the reference policy's chunk
rate, every 8 steps), under a bar that grows with the step count and turns green from the step the task first
succeeded. Nothing in a frame changes the episode: the render camera and the strip read the scene and the
observation, they do not step the physics (test_evaluation checks the state digest with and without videos).

Files: `<out>/videos/<task>/ep<episode>_seed<seed>_<success|failure>.mp4`, H.264 at the task's control rate (20
steps a second on every task: real time). The episode's record names its video (`video`, relative to `<out>`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

import numpy as np

VIDEO_DIR = "videos"
BAR_HEIGHT = 8  # px: the step bar under the frame
BAR_COLOURS = {False: (200, 200, 200), True: (40, 190, 70)}  # before the first success, from it on
BACKGROUND = 20  # grey level behind the camera strip


def video_name(task: str, episode: int, seed: int, success: bool) -> str:
    """The episode's video, relative to the results folder."""
    return f"{VIDEO_DIR}/{task}/ep{episode:03d}_seed{seed}_{'success' if success else 'failure'}.mp4"


def observed_images(obs) -> list[np.ndarray]:
    """The RGB images in an observation (ManiSkill's `sensor_data`, first env), camera uids in sorted order; [] when
    the observation carries none (a state obs mode, or a step taken with the sensors off)."""
    data = obs.get("sensor_data") if isinstance(obs, dict) else None
    images = []
    for uid in sorted(data or {}):
        rgb = data[uid].get("rgb") if isinstance(data[uid], dict) else None
        if rgb is not None:
            a = rgb.cpu().numpy() if hasattr(rgb, "cpu") else np.asarray(rgb)
            images.append(np.ascontiguousarray(a[0] if a.ndim == 4 else a)[..., :3].astype(np.uint8))
    return images


def _resize_nearest(image: np.ndarray, height: int, width: int) -> np.ndarray:
    rows = (np.arange(height) * image.shape[0] // height).clip(0, image.shape[0] - 1)
    cols = (np.arange(width) * image.shape[1] // width).clip(0, image.shape[1] - 1)
    return image[rows][:, cols]


def compose_frame(view: np.ndarray, seen: list[np.ndarray], progress: float, succeeded: bool) -> np.ndarray:
    """One video frame: `view` (H x W x 3), under it the strip of `seen` images (each resized to W / len(seen) wide,
    square), under that the step bar (`progress` in [0, 1]). Height and width even (H.264's 4:2:0)."""
    view = np.asarray(view, dtype=np.uint8)[..., :3]
    width = view.shape[1] - view.shape[1] % 2
    parts = [view[: view.shape[0] - view.shape[0] % 2, :width]]
    if seen:
        side = (width // len(seen)) // 2 * 2
        strip = np.full((side, width, 3), BACKGROUND, np.uint8)
        for i, image in enumerate(seen):
            strip[:, i * side:(i + 1) * side] = _resize_nearest(image, side, side)
        parts.append(strip)
    bar = np.full((BAR_HEIGHT, width, 3), BACKGROUND, np.uint8)
    bar[:, : int(round(width * min(max(progress, 0.0), 1.0)))] = BAR_COLOURS[bool(succeeded)]
    parts.append(bar)
    return np.concatenate(parts, axis=0)


class EpisodeVideo:
    """One episode's video, its frames streamed to ffmpeg as they come (a 1000-step episode would hold ~1 GB of
    frames in memory) into `<folder>/<name>.part`, renamed to its final name when the episode ends."""

    def __init__(self, folder: Path, horizon: int, fps: int):
        self.folder = Path(folder)
        self.horizon = max(int(horizon), 1)
        self.fps = max(int(fps), 1)
        self.tmp = self.folder / f"episode.{os.getpid()}.mp4.part"
        self.seen: list[np.ndarray] = []
        self.succeeded = False
        self.frames = 0
        self._writer = None

    def add(self, base, obs, step: int, success: bool) -> None:
        """The frame after control step `step` (0: the reset) of env `base` (its render camera), `obs` the
        observation the step returned (its images, if any, replace the strip)."""
        images = observed_images(obs)
        if images:
            self.seen = images
        self.succeeded = self.succeeded or bool(success)
        view = base.render_rgb_array()
        view = view.cpu().numpy() if hasattr(view, "cpu") else np.asarray(view)
        frame = compose_frame(view[0] if view.ndim == 4 else view, self.seen, step / self.horizon, self.succeeded)
        if self._writer is None:
            import imageio_ffmpeg

            self.folder.mkdir(parents=True, exist_ok=True)
            self._size = frame.shape[:2]
            self._writer = imageio_ffmpeg.write_frames(
                str(self.tmp), (frame.shape[1], frame.shape[0]), fps=self.fps, codec="libx264", pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p", macro_block_size=1, ffmpeg_log_level="error", output_params=["-f", "mp4"])
            self._writer.send(None)
        if frame.shape[:2] != self._size:  # the strip appeared or changed its camera count
            frame = _fit(frame, self._size)
        self._writer.send(np.ascontiguousarray(frame))
        self.frames += 1

    def finish(self, path: Path) -> None:
        """Close the file and give it its final name `path` (an earlier file there, of an interrupted run of the same
        episode, is replaced: a resumed run re-runs only episodes with no record)."""
        if self._writer is None:
            raise ValueError(f"{path}: an episode video with no frames")
        self._writer.close()
        self._writer = None
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        os.replace(self.tmp, path)

    def discard(self) -> None:
        """Drop the partial file (the episode raised)."""
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:
                pass
            self._writer = None
        self.tmp.unlink(missing_ok=True)


def _fit(frame: np.ndarray, size: tuple) -> np.ndarray:
    """`frame` cropped or padded (at the bottom) to `size` (height, width)."""
    h, w = size
    out = np.full((h, w, 3), BACKGROUND, np.uint8)
    out[: min(h, frame.shape[0]), : min(w, frame.shape[1])] = frame[:h, :w]
    return out


def check_videos_option(videos: Optional[int], ray_address: Optional[str]) -> int:
    """`--videos K` as an int >= 0; a clear error for a negative K or with Ray (whose workers may write to another
    machine's disk)."""
    k = int(videos or 0)
    if k < 0:
        raise ValueError(f"--videos must be >= 0 (episodes per task to film), got {k}")
    if k and ray_address is not None:
        raise ValueError("--videos writes each video where its episode runs: run without --ray (or with --workers) "
                         "to film episodes")
    return k
