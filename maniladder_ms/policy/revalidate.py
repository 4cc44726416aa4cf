"""Carry a calibration result over to the current version of its task when nothing the task is judged or built by
has changed and its demos come out the same.

`provenance.task_hash` covers every module a task imports, so an edit to a shared module (a LEAP posture added to
`solvers/postures.py`, which 27 of the 28 tasks of the ladder's first round import) makes every result of every
task that imports it stale, though each task plays out exactly as before. The ladder runs for days while other
tasks are built; without this it would redo every task after every such edit. `revalidate` tells the two apart for
one result:

1. the task's own parts are unchanged since the result's commit (`git diff`): its catalog row's played fields, its
   task module and its solver module (the robot assets and the shipped decompositions are every task's: a new
   task's decomposition changes every hash, and what they do to this task is in its demos); and
2. its calibration demos (the protocol's count and first seed), regenerated with the current code, are
   bit-identical, actions and env states, to the demos the result was trained on (`demos_digest`): the solver, the
   shared solver and env code it runs and the simulation along those episodes are unchanged.

Then the result lists the current version under `equivalent_versions` (task hash, commit, the evidence), which
`calibrate.stale_reason` and the calibration record accept as the same task. Not covered (said in each entry): a
shared change that shows only off the demos' paths, in the policy's own rollouts, or only in rendering.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import tempfile
from pathlib import Path
from typing import Optional

from maniladder_ms.provenance import PLAYED_FIELDS, ROOT, git_commit, task_hash

EVIDENCE = ("own parts unchanged (catalog row, task and solver modules); {n} calibration demos regenerated "
            "bit-identical (actions and env states); not checked: the policy's own rollouts, rendering")


def demos_digest(h5: Path) -> str:
    """sha256 over every episode's actions and env states in a ManiSkill trajectory file, in episode order."""
    import h5py
    import numpy as np

    h = hashlib.sha256()
    with h5py.File(h5, "r") as f:
        for key in sorted(f.keys(), key=lambda k: int(k.split("_")[-1]) if k.split("_")[-1].isdigit() else k):
            def visit(name, obj):
                if isinstance(obj, h5py.Dataset) and (name == "actions" or name.startswith("env_states")):
                    h.update(name.encode() + b"\0" + np.ascontiguousarray(obj[()]).tobytes())
            f[key].visititems(visit)
    return h.hexdigest()


def _git(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=60)


def _catalog_row(yaml_text: str, task_id: str) -> dict:
    import yaml

    rows = {t["id"]: t for t in yaml.safe_load(yaml_text)["tasks"]}
    return {k: rows[task_id].get(k) for k in PLAYED_FIELDS} if task_id in rows else {}


def task_hash_at(commit: str, task_id: str) -> str:
    """`task_hash(task_id)` with each of the task's source files (today's import closure) as committed at `commit`;
    its catalog row and data folders are today's, so a row changed since raises. Equal to a result's hash, it proves
    what the result measured: those sources with this row and these data folders."""
    from maniladder_ms.provenance import task_hash_parts

    if row_changed_since(task_id, commit):
        raise ValueError(f"{task_id}: its catalog row changed since {commit}")
    parts = dict(task_hash_parts(task_id))
    for f in parts:
        if f.endswith(".py"):
            blob = subprocess.run(["git", "-C", str(ROOT), "show", f"{commit}:{f}"], capture_output=True, timeout=60)
            if blob.returncode != 0:
                raise ValueError(f"{task_id}: {f} is not in commit {commit}")
            parts[f] = hashlib.sha256(blob.stdout).hexdigest()
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()[:16]


def measured_commit(task_id: str, commit: str, measured_hash: Optional[str]) -> str:
    """The commit whose task a result measured. A checkout with uncommitted edits records `<commit>+dirty`; the
    result still measured `<commit>`'s task when the task's hash there is the result's (the edits touched nothing
    the task imports: a calibration job that writes its records into its own checkout makes it dirty that way).
    Where the task's catalog row changed since, the clean commit is returned whatever the edits were: the result is
    stale either way, and `own_parts_changed` names the row."""
    if not commit:
        raise ValueError(f"{task_id}: the result records no commit, so nothing names what it measured")
    if not commit.endswith("+dirty"):
        return commit
    clean = commit[: -len("+dirty")]
    if row_changed_since(task_id, clean):
        return clean
    at_clean = task_hash_at(clean, task_id)
    if at_clean != measured_hash:
        raise ValueError(f"{task_id}: the result's commit {commit} does not name what it measured (the task at {clean} "
                         f"is version {at_clean}, the result measured {measured_hash}: uncommitted edits changed it)")
    return clean


def own_parts_changed(task_id: str, commit: str) -> list[str]:
    """What of the task's own parts differs between `commit` (a clean one: `measured_commit`) and the checkout now
    (empty: nothing)."""
    from maniladder_ms import solvers, tasks

    if commit.endswith("+dirty"):
        raise ValueError(f"{task_id}: {commit} does not name what was measured (`measured_commit` finds the clean one)")
    paths = [f"maniladder_ms/tasks/{tasks.FILES[task_id]}"]
    if task_id in solvers.solver_files():
        paths.append(f"maniladder_ms/solvers/{solvers.solver_files()[task_id]}")
    changed = [p for p in paths if _git("diff", "--quiet", commit, "--", p).returncode != 0]
    if row_changed_since(task_id, commit):
        changed.append("its catalog row")
    return changed


def row_changed_since(task_id: str, commit: str) -> bool:
    """Whether the task's catalog row (its played fields) differs between `commit` and the checkout now."""
    catalog = "maniladder_ms/data/task_catalog.yaml"
    old = _git("show", f"{commit}:{catalog}")
    if old.returncode != 0:
        raise ValueError(f"{task_id}: commit {commit} is not in this checkout ({old.stderr.strip()})")
    return _catalog_row(old.stdout, task_id) != _catalog_row((ROOT / catalog).read_text(), task_id)


def revalidate(result_path: Path, work: Path, progress: bool = True) -> dict:
    """Check one result file against the current version of its task (see the module doc); on success add the
    version to its `equivalent_versions` and rewrite it. Returns {"task", "status": current | equivalent | changed,
    "why"} (and the rewritten "result" when equivalent); raises ValueError where it cannot tell (no commit, or no
    record of the demos the result was trained on: neither its `demos_digest` nor the demos in `work`).

    A result of the current version without a `demos_digest` (results written before calibrate recorded it) gets
    one: from its demos in `work` where they are, else from the demos regenerated now, which are the trained-on
    demos because the version is the measured one (the determinism the equivalence check itself rests on). Later
    revalidations then need no work folder."""
    result_path = Path(result_path)
    r = json.loads(result_path.read_text())
    task, now = r["task"], task_hash(r["task"])
    trained_on = _trained_on_demos(r, work)
    if now in equivalent_hashes(r):
        if r.get("demos_digest"):
            return {"task": task, "status": "current", "why": f"version {now} is the one measured"}
        r["demos_digest"] = demos_digest(trained_on) if trained_on.is_file() else _regenerated_digest(r, progress)
        _write(result_path, r)
        return {"task": task, "status": "current", "why": f"version {now} is the one measured; its demos' digest "
                                                          "is now recorded", "result": r}
    changed = own_parts_changed(task, measured_commit(task, r.get("environment", {}).get("commit", ""),
                                                      r.get("task_hash")))
    if changed:
        return {"task": task, "status": "changed", "why": "changed since the result: " + ", ".join(changed)}
    if not r.get("demos_digest") and not trained_on.is_file():
        raise ValueError(f"{task}: the result records no demos_digest and the demos it was trained on are not in "
                         f"{work} ({trained_on})")
    before = r.get("demos_digest") or demos_digest(trained_on)
    n = r["calibration"]["demos"]
    if _regenerated_digest(r, progress) != before:
        return {"task": task, "status": "changed", "why": f"its {n} demos regenerated now differ from those trained on"}
    r["demos_digest"] = before
    entry = {"task_hash": now, "commit": git_commit(), "evidence": EVIDENCE.format(n=n)}
    r.setdefault("equivalent_versions", []).append(entry)
    _write(result_path, r)
    return {"task": task, "status": "equivalent", "why": f"version {now} plays as {r['task_hash']}: {entry['evidence']}",
            "result": r}


def _demo_mode(r: dict) -> str:
    """The control mode the result's calibration demos were recorded in."""
    from maniladder_ms.policy.calibrate import demo_control_mode_for

    return r.get("demo_control_mode") or demo_control_mode_for(r["task"])


def _trained_on_demos(r: dict, work: Path) -> Path:
    """Where a calibration work folder keeps the demos the result was trained on."""
    from maniladder_ms.demos.files import demo_path

    return demo_path(Path(work) / r["task"] / r["task_hash"] / "demos", r["task"], "none", _demo_mode(r))


def _regenerated_digest(r: dict, progress: bool) -> str:
    """`demos_digest` of the result's calibration demos (its count and first seed) generated with the current code."""
    from maniladder_ms.demos.recording import generate

    with tempfile.TemporaryDirectory() as tmp:
        report = generate(r["task"], r["calibration"]["demos"], Path(tmp), seed=r["calibration"]["demo_seed"],
                          control_mode=_demo_mode(r), progress=progress)
        return demos_digest(Path(report.path))


def _write(result_path: Path, r: dict) -> None:
    tmp_path = result_path.with_suffix(".partial")
    tmp_path.write_text(json.dumps(r, indent=1))
    tmp_path.replace(result_path)


def equivalent_hashes(result: dict) -> set[str]:
    """Every task version a result stands for: the one measured and those revalidated since."""
    return {result.get("task_hash"), *(e["task_hash"] for e in result.get("equivalent_versions", []))} - {None}


def revalidate_folder(out: Path, work: Path, tasks: Optional[list[str]] = None, progress: bool = True,
                      log=print) -> list[dict]:
    """`revalidate` every result in `out` (or those of `tasks`); one line each."""
    from maniladder_ms.policy.calibrate import load_results

    rows = []
    for r in load_results(out):
        if tasks and r["task"] not in tasks:
            continue
        try:
            row = revalidate(Path(out) / f"{r['task']}.json", work, progress=progress)
        except ValueError as e:
            row = {"task": r["task"], "status": "unknown", "why": str(e)}
        log(f"{row['task']}: {row['status']}: {row['why']}")
        rows.append(row)
    return rows
