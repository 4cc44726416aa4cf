"""A wheel of a source checkout, built and installed into a bare folder: what the wheel-install checks replay
demos from (scripts/maniskill_replay_samples.py, tests/test_demos.py::test_wheel_install_replays_coacd_samples).
Needs a checkout (setup.cfg, pyproject.toml, README.md beside the package), not an installed wheel."""

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
