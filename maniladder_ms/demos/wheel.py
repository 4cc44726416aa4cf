"""A wheel of a source checkout, built and installed into a bare folder, and ManiSkill's own `replay_trajectory`
run from such an install: what the install checks use (scripts/maniskill_replay_samples.py,
tests/test_demos.py::test_wheel_install_replays_coacd_samples). `build_wheel_site` needs a checkout (setup.cfg,
pyproject.toml, README.md beside the package), not an installed wheel."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

from ..paths import REPO_DIR


def build_wheel_site(tmp: Path, repo: Path = REPO_DIR) -> tuple[Path, Path]:
    """Build a wheel of `repo` into `tmp/wheel` and install it with --target into `tmp/site`; returns (wheel,
    site). A copy of the tree (`tmp/src`) builds it, so no build/ or egg-info is written into the checkout."""
    src = tmp / "src"
    shutil.copytree(repo / "maniladder_ms", src / "maniladder_ms", ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("setup.cfg", "pyproject.toml", "README.md"):
        shutil.copy(repo / name, src / name)
    pip = [sys.executable, "-m", "pip", "-q", "--disable-pip-version-check"]
    subprocess.run([*pip, "wheel", "--no-deps", "--no-build-isolation", str(src), "-w", str(tmp / "wheel")],
                   check=True, timeout=300)
    (wheel,) = (tmp / "wheel").glob("maniladder_ms-*.whl")
    site = tmp / "site"
    subprocess.run([*pip, "install", "--no-deps", "--target", str(site), str(wheel)], check=True, timeout=300)
    return wheel, site


def maniskill_replay(path: Path, install: Path, work: Path, cache: Path, cwd: Path,
                     timeout: float | None = None) -> subprocess.CompletedProcess:
    """ManiSkill's `replay_trajectory` (from actions, state obs, saving the replayed trajectory, CPU physics) of a
    copy of the demo file `path` in `work` (the replay writes its output beside the file it reads), with the
    package imported from `install` (a source tree or `build_wheel_site`'s site) and convex decompositions cached
    in `cache`; its stdout and stderr captured as text."""
    work.mkdir(parents=True, exist_ok=True)
    for suffix in (".h5", ".json"):
        shutil.copy(path.with_suffix(suffix), work / path.with_suffix(suffix).name)
    return subprocess.run(
        [sys.executable, "-m", "mani_skill.trajectory.replay_trajectory", "--traj-path", str(work / path.name),
         "-o", "state", "--save-traj", "-b", "physx_cpu"], cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(install), "MANILADDER_CACHE": str(cache)},
        capture_output=True, text=True, timeout=timeout)
