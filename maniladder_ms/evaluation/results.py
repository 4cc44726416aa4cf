"""The results folder of one evaluation run.

    <out>/manifest.json    protocol version, policy, obs mode, base seed, episodes asked, tasks and
                           the ones skipped (with why); written first, checked on every resume
    <out>/episodes.jsonl   one JSON object per finished episode, appended (and fsynced) as it ends
    <out>/summary.json     the statistics (`stats.summarize`), rewritten at the end of every run

A folder written under another protocol version, or by another policy / obs mode / base seed / instruction mode /
camera subset (`--cameras`; a folder from before that key holds "all"), is refused rather than mixed. A kill loses at most the episodes that were running: every finished one is
on disk, and a torn last line (a kill mid-write) is dropped on resume.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Optional

from . import PROTOCOL_VERSION

MANIFEST = "manifest.json"
EPISODES = "episodes.jsonl"
SUMMARY = "summary.json"
# manifest keys that must match for a resume to add to a folder, with the value a folder written before the
# key existed ran under
IDENTITY_KEYS = ("protocol_version", "policy", "obs_mode", "seed", "instructions", "cameras")
ALL_CAMERAS = "all"  # the `cameras` of a run whose policy could see every camera of each task
IDENTITY_DEFAULTS = {"instructions": "canonical", "cameras": ALL_CAMERAS}


def run_cameras(manifest: dict) -> str:
    """The camera subset a run's policy could see, as text: `all`, or the uids comma-separated."""
    cams = manifest.get("cameras", ALL_CAMERAS)
    return cams if isinstance(cams, str) else ",".join(cams)


class ResultsError(ValueError):
    """A results folder that cannot be used (other protocol version or run, not a results folder)."""


def read_manifest(out: Path) -> Optional[dict]:
    path = Path(out) / MANIFEST
    if not path.exists():
        return None
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ResultsError(f"{path}: not valid JSON ({e})") from None


def check_protocol(manifest: dict, where) -> None:
    version = manifest.get("protocol_version")
    if version != PROTOCOL_VERSION:
        raise ResultsError(
            f"{where} was written under evaluation protocol version {version}, this is version "
            f"{PROTOCOL_VERSION}; results of different protocols are not comparable and are not mixed. "
            "Re-run the evaluation into a new folder."
        )


def open_run(out: Path, manifest: dict) -> dict:
    """Create `out` with `manifest`, or check that an existing folder is the same run and merge the
    task list / episode count into its manifest. Returns the manifest on disk."""
    out = Path(out)
    old = read_manifest(out)
    if old is None:
        if out.exists() and (out / EPISODES).exists():
            raise ResultsError(f"{out} has {EPISODES} but no {MANIFEST}; not a results folder of this tool")
        out.mkdir(parents=True, exist_ok=True)
        manifest = dict(manifest, created=time.strftime("%Y-%m-%dT%H:%M:%S"))
        _write_json(out / MANIFEST, manifest)
        return manifest
    check_protocol(old, out)
    def value(m: dict, k: str):  # a manifest written before a key existed holds its default
        return m.get(k, IDENTITY_DEFAULTS.get(k))

    diff = [k for k in IDENTITY_KEYS if value(old, k) != value(manifest, k)]
    if diff:
        what = ", ".join(f"{k} {value(old, k)!r} there vs {value(manifest, k)!r} now" for k in diff)
        raise ResultsError(f"{out} holds another run ({what}); use another --out folder to keep both")
    merged = dict(old)
    merged["tasks"] = list(dict.fromkeys(list(old.get("tasks", [])) + list(manifest.get("tasks", []))))
    skipped = dict(old.get("skipped", {}))
    skipped.update(manifest.get("skipped", {}))
    merged["skipped"] = {k: v for k, v in skipped.items() if k not in merged["tasks"]}
    merged["episodes"] = max(int(old.get("episodes", 0)), int(manifest.get("episodes", 0)))
    merged["resumed"] = time.strftime("%Y-%m-%dT%H:%M:%S")
    for k in ("task_env", "maniladder_version"):
        if k in manifest:
            merged[k] = {**old.get(k, {}), **manifest[k]} if isinstance(manifest[k], dict) else manifest[k]
    _write_json(out / MANIFEST, merged)
    return merged


def read_episodes(out: Path, repair: bool = False) -> list[dict]:
    """The finished episodes of a folder (first record per (task, episode)); a torn last line (a kill
    mid-write) is ignored, and with `repair` cut off the file so appends start on a clean line."""
    path = Path(out) / EPISODES
    if not path.exists():
        return []
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        cut = data.rfind(b"\n") + 1
        data = data[:cut]
        if repair:
            with open(path, "r+b") as f:
                f.truncate(cut)
    records, seen = [], set()
    for i, line in enumerate(data.decode("utf-8", errors="replace").splitlines()):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            raise ResultsError(f"{path}:{i + 1}: not a JSON record; the file was edited or corrupted") from None
        key = (rec.get("task"), rec.get("episode"))
        if key not in seen:
            seen.add(key)
            records.append(rec)
    return records


class EpisodeLog:
    """Appends one record per line, flushed and fsynced, so a kill loses no finished episode."""

    def __init__(self, out: Path):
        self.path = Path(out) / EPISODES
        self._f = open(self.path, "a", encoding="utf-8")

    def append(self, record: dict):
        self._f.write(json.dumps(record, sort_keys=True) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self):
        self._f.close()


def load_results(out) -> dict:
    """{"dir", "manifest", "episodes"} of a results folder; refuses other protocol versions."""
    out = Path(out)
    manifest = read_manifest(out)
    if manifest is None:
        raise ResultsError(f"{out} is not a results folder (no {MANIFEST}); run `maniladder eval --out {out}` first")
    check_protocol(manifest, out)
    return {"dir": out, "manifest": manifest, "episodes": read_episodes(out)}


def find_result_dirs(paths) -> list[Path]:
    """Result folders among `paths`: a folder with a manifest, or the run folders directly inside one."""
    found = []
    for p in map(Path, paths):
        if (p / MANIFEST).exists():
            found.append(p)
            continue
        subs = sorted(d for d in p.iterdir() if (d / MANIFEST).exists()) if p.is_dir() else []
        if not subs:
            raise ResultsError(f"{p}: no {MANIFEST} in it or in its sub-folders; not a results folder")
        found.extend(subs)
    return found


def write_summary(out: Path, summary: dict):
    _write_json(Path(out) / SUMMARY, summary)


def _write_json(path: Path, obj):
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(obj, indent=2, sort_keys=True, default=_jsonable))
    os.replace(tmp, path)


def _jsonable(x):
    try:
        return x.item()
    except AttributeError:
        return str(x)
