"""Check that a refactor left task solvers' actions unchanged: each committed sample's first episode is recorded
again from its seed (fresh env, as demos are recorded) and its actions compared bit for bit with the committed ones.

    python scripts/same_actions.py TASK [TASK ...]     # or --all; exit 1 if any differs

A committed sample recorded before an earlier solver change differs from today's solver already: record today's
actions first with `--write-reference DIR` on the commit before the refactor, then compare with `--reference DIR`
(a task with `DIR/<Task>.<control mode>.npy` is compared to that file instead of its committed sample).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from maniladder_ms.demos.files import episode_arrays, load_demo_json, open_demo_h5
from maniladder_ms.demos.recording import generate
from maniladder_ms.paths import REPO_DIR


def sample_files(task_id: str, every_mode: bool) -> list[Path]:
    """The committed sample files of `task_id`: the one in its solver's own control mode (all with `every_mode`)."""
    from maniladder_ms.solvers import solver_for

    files = sorted((Path(REPO_DIR) / "demos" / task_id).glob("*.h5"))
    own = [p for p in files if f".{solver_for(task_id).control_mode}." in p.name]
    return files if every_mode or not own else own


def check(task_id: str, every_mode: bool = False, reference: Path | None = None, write: Path | None = None) -> list[str]:
    """One line per committed sample file of `task_id`: same / DIFFERENT, with the first differing step."""
    lines = []
    for path in sample_files(task_id, every_mode):
        meta = load_demo_json(path)
        kwargs = meta["env_info"]["env_kwargs"]
        episode = meta["episodes"][0]
        with open_demo_h5(path) as h5:
            committed = np.asarray(episode_arrays(h5, episode["episode_id"], "actions")[0])
        with tempfile.TemporaryDirectory() as scratch:
            report = generate(task_id, 1, Path(scratch), seed=episode["episode_seed"], control_mode=kwargs["control_mode"],
                              obs_mode=kwargs.get("obs_mode", "none"), progress=False, max_attempts=1)
            new_meta = load_demo_json(report.path)
            with open_demo_h5(report.path) as h5:
                new = np.asarray(episode_arrays(h5, new_meta["episodes"][0]["episode_id"], "actions")[0])
        ref = reference / f"{task_id}.{kwargs['control_mode']}.npy" if reference else None
        if ref is not None and ref.exists():
            committed = np.load(ref)
        if write is not None:
            write.mkdir(parents=True, exist_ok=True)
            np.save(write / f"{task_id}.{kwargs['control_mode']}.npy", new)
        if new.shape == committed.shape and np.array_equal(new, committed):
            lines.append(f"same       {task_id} {path.name} seed {episode['episode_seed']}: {len(new)} steps")
        else:
            n = min(len(new), len(committed))
            diff = np.flatnonzero(np.any(new[:n] != committed[:n], axis=1))
            first = int(diff[0]) if len(diff) else n
            lines.append(f"DIFFERENT  {task_id} {path.name} seed {episode['episode_seed']}: {len(new)} vs "
                         f"{len(committed)} steps, first difference at step {first}")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tasks", nargs="*")
    ap.add_argument("--all", action="store_true", help="every task with committed samples")
    ap.add_argument("--reference", type=Path, help="folder of reference actions (<Task>.<mode>.npy) to compare to")
    ap.add_argument("--write-reference", type=Path, help="save each task's recorded actions in this folder")
    ap.add_argument("--every-mode", action="store_true", help="each control mode's sample, not only the solver's own")
    args = ap.parse_args(argv)
    tasks = sorted(p.name for p in (Path(REPO_DIR) / "demos").iterdir() if p.is_dir()) if args.all else args.tasks
    if not tasks:
        ap.error("name tasks or give --all")
    ok = True
    for task_id in tasks:
        for line in check(task_id, args.every_mode, args.reference, args.write_reference):
            print(line, flush=True)
            ok &= line.startswith("same")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
