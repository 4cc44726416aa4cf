"""scripts/trace_episodes.py: bad input is a clear error and an earlier trace is never overwritten (its traced run
needs a trained checkpoint: README, "trace_episodes")."""

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "scripts" / "trace_episodes.py"


def run(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, cwd=REPO)


def test_a_missing_checkpoint_or_no_episodes_is_a_clear_error(tmp_path):
    r = run("PickPlacePen", tmp_path / "none.pt", tmp_path / "out")
    assert r.returncode == 2 and "no such checkpoint" in r.stderr
    ck = tmp_path / "c.pt"
    ck.write_bytes(b"")
    r = run("PickPlacePen", ck, tmp_path / "out", "--episodes", 0)
    assert r.returncode == 2 and "--episodes must be at least 1" in r.stderr


def test_an_earlier_trace_is_not_overwritten(tmp_path):
    ck = tmp_path / "c.pt"
    ck.write_bytes(b"")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "trace.jsonl").write_text("kept\n")
    r = run("PickPlacePen", ck, tmp_path / "out")
    assert r.returncode == 2 and "exists" in r.stderr
    assert (tmp_path / "out" / "trace.jsonl").read_text() == "kept\n"
