"""Where ManiLadder finds its data and writes what it generates."""

import os
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
REPO_DIR = PACKAGE_DIR.parent
# the robot descriptions: the repo's top-level agents/, reached through the package's data/agents
# symlink in a checkout; a wheel carries the files themselves there
AGENTS_DIR = PACKAGE_DIR / "data" / "agents"


def cache_dir(*parts: str) -> Path:
    """A writable folder for generated assets (textures, meshes), created on first use.

    `$MANILADDER_CACHE` wins; a source checkout caches under its own `assets/.cache`; an installed
    wheel under `~/.cache/maniladder_ms`.
    """
    if os.environ.get("MANILADDER_CACHE"):
        root = Path(os.environ["MANILADDER_CACHE"])
    elif (REPO_DIR / "assets").is_dir() and os.access(REPO_DIR / "assets", os.W_OK):
        root = REPO_DIR / "assets" / ".cache"
    else:
        root = Path.home() / ".cache" / "maniladder_ms"
    path = root.joinpath(*parts)
    path.mkdir(parents=True, exist_ok=True)
    return path
