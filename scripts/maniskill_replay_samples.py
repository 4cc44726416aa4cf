"""ManiSkill's own `replay_trajectory` (from actions, no env states) on the committed samples in demos/, from this
source checkout and from a wheel built from it and installed into a bare folder (run outside the repo, empty
cache): the check that a demo replays to success on either kind of install.

    .venv/bin/python scripts/maniskill_replay_samples.py [TASK ...]      # default: every task with samples

Prints one line per file and install, and exits 1 if any replay does not save every episode as a success.
CI runs the same check on a sample (tests/test_demos.py::test_wheel_install_replays_coacd_samples and the
rgbd conversion test); this is the full sweep (~2-5 min a task on a loaded 2-core machine).
"""

import re
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # this checkout's package, whatever the venv has installed
from maniladder_ms.demos.wheel import build_wheel_site, maniskill_replay  # noqa: E402

SAVED = re.compile(r"(\d+)/(\d+)=[\d.]+% demos saved")


def replay(path: Path, install: Path, tmp: Path, kind: str) -> tuple[bool, str]:
    result = maniskill_replay(path, install, tmp / kind / path.parent.name, tmp / f"cache_{kind}", cwd=tmp)
    found = SAVED.search(result.stdout + result.stderr)
    if found is None:
        return False, f"no result (exit {result.returncode}): {(result.stdout + result.stderr)[-800:]}"
    return found.group(1) == found.group(2), found.group(0)


def main(tasks: list[str]) -> int:
    files = sorted((REPO / "demos").glob("*/trajectory.*.h5"))
    if tasks:
        unknown = sorted(set(tasks) - {f.parent.name for f in files})
        if unknown:
            print(f"no committed samples for: {', '.join(unknown)}", file=sys.stderr)
            return 2
        files = [f for f in files if f.parent.name in tasks]
    failed = 0
    with tempfile.TemporaryDirectory(prefix="maniskill_replay_") as name:
        tmp = Path(name)
        installs = {"source": REPO, "wheel": build_wheel_site(tmp, REPO)[1]}
        for i, path in enumerate(files, 1):
            for kind, install in installs.items():
                start = time.time()
                ok, text = replay(path, install, tmp, kind)
                failed += not ok
                print(f"[{i}/{len(files)}] {kind:6s} {path.parent.name:28s} {path.name:50s} "
                      f"{'ok' if ok else 'FAILED'} {text} ({time.time() - start:.0f} s)", flush=True)
    print(f"{len(files)} files x {len(installs)} installs: {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
