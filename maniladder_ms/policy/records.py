"""A task's calibration record: the development rounds that refined it and the final runs that place it.

The refinement loop: a development run (development seed set, one training
seed) -> a change to the task (a catalog edit with a YAML comment, or its geometry, tolerance, stages) -> another
development run, at most `MAX_DEVELOPMENT_ROUNDS` a task; then a final run (final seed set, the protocol's training
seeds pooled, its declared episode count) whose number places the task. `maniladder calibrate --record DIR` appends
each run to `DIR/<task>.json` (the committed records are `docs/calibration/records/`), and `maniladder show TASK`
prints them.

An entry holds what was measured (successes, interval, measured level, verdict against the catalog level), on what
(protocol, purpose, seed set, task hash, commit, the catalog params and horizon at the time) and what changed since
the previous entry (the params that differ, and the reason given with `--change`). A run of a task version that
is already recorded (same task hash, protocol, purpose and network configuration) is the same measurement: it
adds nothing. A changed task version must say what changed (`--change`) before its run starts.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

from maniladder_ms.paths import REPO_DIR

# the paper refines a task in about four rounds; a fifth development round needs `extra_round` (say why in --change)
MAX_DEVELOPMENT_ROUNDS = 4
COMMITTED_RECORDS = REPO_DIR / "docs" / "calibration" / "records"


class RecordError(ValueError):
    """A run that the record's rules refuse (no reason for a changed task, a round past the limit)."""


def load_record(records: Path, task: str) -> dict:
    path = Path(records) / f"{task}.json"
    return json.loads(path.read_text()) if path.is_file() else {"task": task, "entries": []}


def _key(entry: dict) -> tuple:
    return entry["task_hash"], entry["protocol"], entry["purpose"], json.dumps(entry["config"], sort_keys=True)


def _versions(entry: dict) -> set[str]:
    """The task versions an entry stands for: the one measured and those revalidated as playing the same
    (`policy.revalidate`)."""
    return {entry["task_hash"], *entry.get("equivalent_task_hashes", [])}


def add_equivalent(records: Path, result: dict) -> dict:
    """Note in the record the versions `result` was revalidated for (its `equivalent_versions`), on the entries of
    the version it measured; a later run of such a version needs no `--change`. Returns the record."""
    record = load_record(records, result["task"])
    new = [e["task_hash"] for e in result.get("equivalent_versions", [])]
    for entry in record["entries"]:
        if entry["task_hash"] == result["task_hash"]:
            entry["equivalent_task_hashes"] = sorted(set(entry.get("equivalent_task_hashes", [])) | set(new))
    if record["entries"]:
        _save(records, record)
    return record


def _save(records: Path, record: dict) -> None:
    """Write a task's record whole or not at all (a temporary file, then a rename)."""
    path = Path(records) / f"{record['task']}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".partial")
    tmp.write_text(json.dumps(record, indent=1))
    tmp.replace(path)


def _changes(before: Optional[dict], params: dict, horizon: int) -> dict:
    """{name: [before, now]} over the catalog params and the horizon that differ from the previous entry's."""
    if before is None:
        return {}
    old = {**before["params"], "horizon": before["horizon"]}
    new = {**params, "horizon": horizon}
    return {k: [old.get(k), new.get(k)] for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)}


def _added(record: dict, task_hash: str, protocol: str, purpose: str, config: dict, reason: Optional[str],
           extra_round: bool) -> bool:
    """Whether a run's entry would be added to `record` (False: that measurement is recorded already); raises
    RecordError where the record's rules refuse it."""
    task, entries = record["task"], record["entries"]
    if any(task_hash in _versions(e) and _key(e)[1:] == (protocol, purpose, json.dumps(config, sort_keys=True))
           for e in entries):
        return False  # already recorded (a resume): nothing to add
    if entries and task_hash not in _versions(entries[-1]) and not reason:
        raise RecordError(
            f"{task} changed since its last recorded run (task version {entries[-1]['task_hash']} -> {task_hash}): "
            "say what changed and why with --change TEXT (the catalog's YAML comment gives the measurement)")
    if purpose == "development" and not extra_round:
        rounds = [e for e in entries if e["purpose"] == "development" and e["protocol"] == protocol]
        if len(rounds) >= MAX_DEVELOPMENT_ROUNDS:
            raise RecordError(
                f"{task} has {len(rounds)} development rounds under protocol {protocol} (the loop's limit is "
                f"{MAX_DEVELOPMENT_ROUNDS}): run the final calibration, move the task's level (a catalog edit with its "
                "reason), or pass --extra-round with --change saying why")
    return True


def check_run(records: Path, task: str, task_hash: str, protocol: str, purpose: str, config: dict,
              reason: Optional[str] = None, extra_round: bool = False) -> None:
    """Before a run starts: refuse it (RecordError) if the record's rules would refuse its entry."""
    _added(load_record(records, task), task_hash, protocol, purpose, config, reason, extra_round)


def record_run(records: Path, result: dict, params: dict, reason: Optional[str] = None,
               extra_round: bool = False) -> dict:
    """Append calibration `result` (a `TaskCalibration.write_result` dict) to its task's record, under the same
    rules as `check_run`; the catalog `params` are those the run measured. Returns the record."""
    task = result["task"]
    record = load_record(records, task)
    if not _added(record, result["task_hash"], result["protocol"], result["purpose"], result["config"], reason,
                  extra_round):
        return record
    entries = record["entries"]
    entries.append({
        "round": len(entries) + 1, "purpose": result["purpose"], "seed_set": result["seed_set"],
        "protocol": result["protocol"], "task_hash": result["task_hash"], "config": result["config"],
        "commit": result.get("environment", {}).get("commit"), "time": result.get("time"),
        "catalog_level": result["catalog_level"], "params": params, "horizon": result["horizon"],
        "change": _changes(entries[-1] if entries else None, params, result["horizon"]), "reason": reason,
        "successes": result["successes"], "episodes": result["episodes"], "success": result["success"],
        "ci95": result["ci95"], "training_seeds": len(result.get("per_training_seed", {})) or 1,
        "measured_level": result["measured_level"], "verdict": result["verdict"],
    })
    _save(records, record)
    return record


def record_lines(record: dict) -> list[str]:
    """The record as text lines, one per entry (for `maniladder show`)."""
    lines = []
    for e in record["entries"]:
        lo, hi = e["ci95"]
        change = ", ".join(f"{k} {a} -> {b}" for k, a, b in ((k, *v) for k, v in e["change"].items()))
        why = f"; {e['reason']}" if e.get("reason") else ""
        lines.append(f"{e['round']}. {e['purpose']} ({e['protocol']}, seed set {e['seed_set']}, {e['training_seeds']} "
                     f"training seed(s), task version {e['task_hash']}): {e['successes']}/{e['episodes']} = "
                     f"{100 * e['success']:.0f}% [{100 * lo:.0f}, {100 * hi:.0f}], interval {e['verdict']} "
                     f"L{e['catalog_level']}'s band" + (f"; changed: {change}" if change else "") + why)
    return lines
