"""Is a task's level measured or a design target?

A task's catalog level is what it was designed for. It becomes a measured placement once the reference policy
(`maniladder calibrate`, LadderFlow) has been run on the task as built, under the current protocol: the committed
results in `docs/calibration/` (a source checkout; an installed wheel has none, so it shows design targets).
A result of an older protocol, or of an older version of the task (`provenance.task_hash`), or one marked
stale, measures nothing about the task now; a development run (one training seed, development seeds: a decision
while refining the task) does not place it either, only a final run does. Every level the CLI and the reports show says which it is.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Optional

from maniladder_ms.provenance import ROOT

COMMITTED_RESULTS = ROOT / "docs" / "calibration"


@lru_cache(maxsize=1)
def measured_results(folder: Path = COMMITTED_RESULTS) -> dict[str, dict]:
    """{task: result} of the current protocol's committed results that still measure their task as built and are
    not development runs."""
    from maniladder_ms.policy.calibrate import load_results, stale_reason

    if not Path(folder).is_dir():
        return {}
    return {r["task"]: r for r in load_results(folder) if r.get("purpose") != "development" and not stale_reason(r)}


def measured(task_id: str) -> Optional[dict]:
    return measured_results().get(task_id)


def level_label(spec) -> str:
    """"L1 target" or "L1 measured v4 (72%)": the catalog level, and whether it is measured."""
    from maniladder_ms.policy.flow import PROTOCOL_VERSION

    r = measured(spec.id)
    if r is None:
        return f"L{spec.level} target"
    return f"L{spec.level} measured {PROTOCOL_VERSION} ({100 * r['success']:.0f}%, {r['measured_level_text']})"


def levels_note(specs) -> str:
    """One line under any table of levels: how many are measured, under which protocol; the rest are targets."""
    from maniladder_ms.policy.flow import PROTOCOL_VERSION

    specs = list(specs)
    n = sum(measured(s.id) is not None for s in specs)
    if len(specs) == 1:
        return ("measured" if n else f"the catalog's design target, not measured under the current protocol "
                                      f"(LadderFlow {PROTOCOL_VERSION}) yet")
    if n == 0:
        return (f"levels are the catalog's design targets: none of these {len(specs)} tasks is measured under the "
                f"current protocol (LadderFlow {PROTOCOL_VERSION}) yet; `maniladder report docs/calibration` shows "
                "older measurements")
    return (f"levels: {n} of {len(specs)} measured under LadderFlow {PROTOCOL_VERSION} (`maniladder report "
            "docs/calibration`); the others are the catalog's design targets")
