"""Package code carries no lab notes: no work-log words ("session", "sessions", any case) and no work branch
names (`helper/<branch>`) in any maniladder_ms/**/*.py. How a result was reached belongs in the commit message
or the issue, not in the module a newcomer reads."""

import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "maniladder_ms"
LAB_NOTES = re.compile(r"\bsessions?\b|\bhelper/[\w.-]+", re.IGNORECASE)


def lab_notes(root: Path = PACKAGE) -> list[str]:
    """`file:line: text` of every line under `root` (*.py) with a lab note."""
    found = []
    for path in sorted(root.rglob("*.py")):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if LAB_NOTES.search(line):
                found.append(f"{path.relative_to(root.parent)}:{n}: {line.strip()[:100]}")
    return found


def test_the_pattern_finds_lab_notes_and_only_them(tmp_path):
    (tmp_path / "a.py").write_text('"""Done in Session 17 (helper/rackhand2)."""\nx = 1  # two sessions\n')
    (tmp_path / "b.py").write_text("session_id = 1\nobsession = 2\nhelpers = 3  # see solvers/helper.py\n")
    assert [f.split(":")[:2] for f in lab_notes(tmp_path)] == [[f"{tmp_path.name}/a.py", "1"],
                                                                [f"{tmp_path.name}/a.py", "2"]]


def test_package_code_has_no_lab_notes():
    found = lab_notes()
    assert not found, f"{len(found)} line(s) with lab notes (session / helper/<branch>):\n" + "\n".join(found)
