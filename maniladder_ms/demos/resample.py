"""`maniladder demos resample`: re-record committed demo samples after a deliberate physics change.

A change to a task, an object or the simulation settings can make the committed samples (`demos/`) no longer
replay from their actions. Each sample file is recorded again with the same task, obs mode, control mode,
instruction mode and episode count (seeds from `seed` on, as `demos generate` does), into a scratch folder; the new file replaces
the old one only once every episode of it replays to success from its actions (`verify`).
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from tqdm import tqdm

from .files import DEMO_NAME, DemoFileError, demo_path, json_path, load_demo_json
from .recording import generate
from .verify import EpisodeCheck, verify


@dataclass
class ResampleResult:
    path: Path
    episodes: int
    checks: list[EpisodeCheck]

    @property
    def ok(self) -> bool:
        return len(self.checks) == self.episodes and all(c.success_from_actions for c in self.checks)

    @property
    def max_drift(self) -> float:
        return max((c.max_drift for c in self.checks), default=0.0)


def sample_files(root: Path, tasks: list[str] | None = None) -> list[Path]:
    """The demo files under `root/<TaskId>/` of `tasks` (default: every task folder there)."""
    root = Path(root)
    if tasks:
        folders = [root / t for t in tasks]
    else:
        folders = sorted(p for p in root.iterdir() if p.is_dir()) if root.is_dir() else []
    missing = [str(f) for f in folders if not any(f.glob(f"{DEMO_NAME}.*.h5"))]
    if missing:
        raise DemoFileError(f"no demo files in {', '.join(missing)}")
    files = [p for f in folders for p in sorted(f.glob(f"{DEMO_NAME}.*.h5"))]
    if not files:
        raise DemoFileError(f"no demo files under {root}")
    return files


def resample_file(path: Path, seed: int = 0, workers: int = 1, progress: bool = True) -> ResampleResult:
    """Record `path` again in its task, obs mode, control mode and episode count; replace it once it verifies."""
    path = Path(path)
    meta = load_demo_json(path)
    kwargs = meta["env_info"].get("env_kwargs", {})
    obs_mode, control_mode = kwargs.get("obs_mode", "none"), kwargs["control_mode"]
    if demo_path(path.parent.parent, meta["task_spec"].id, obs_mode, control_mode) != path:
        raise DemoFileError(f"{path}: name does not match its json ({obs_mode}, {control_mode})")
    num = len(meta["episodes"])
    with tempfile.TemporaryDirectory(prefix=".resample-", dir=path.parent) as scratch:
        report = generate(meta["task_spec"].id, num, Path(scratch), seed=seed, control_mode=control_mode,
                          obs_mode=obs_mode, workers=workers, progress=progress,
                          instructions=meta.get("instructions", "canonical"))
        result = ResampleResult(path, num, verify(report.path, progress=progress))
        if result.ok:
            shutil.move(json_path(report.path), json_path(path))
            shutil.move(report.path, path)
    return result


def resample(files: list[Path], seed: int = 0, workers: int = 1, progress: bool = True) -> list[ResampleResult]:
    """`resample_file` on each of `files`, with a progress bar over the files."""
    results = []
    for path in tqdm(files, desc="resample", unit="file", disable=not progress):
        results.append(resample_file(path, seed=seed, workers=workers, progress=progress))
    return results
