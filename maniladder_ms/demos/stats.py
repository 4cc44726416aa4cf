"""`maniladder demos stats`: per task demo counts, lengths and solver success, as a table and a PNG."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from maniladder_ms.catalog import default_catalog

from .files import load_demo_json


def dataset_stats(root: Path) -> list[dict]:
    """One row per demo file under `root`, in catalog (ladder) order."""
    rows = []
    for h5 in sorted(Path(root).glob("*/*.h5")):
        if h5.name.endswith(".partial.h5"):
            continue
        meta = load_demo_json(h5)
        spec = meta["task_spec"]
        lengths = np.array([ep["elapsed_steps"] for ep in meta["episodes"]]) if meta["episodes"] else np.zeros(1)
        solver = meta.get("solver", {})
        rows.append(dict(
            task=spec.id, level=spec.level, suite=spec.suite, file=str(h5), control_mode=meta["episodes"][0]["control_mode"]
            if meta["episodes"] else "", demos=len(meta["episodes"]), mean_len=float(lengths.mean()),
            min_len=int(lengths.min()), max_len=int(lengths.max()), horizon=spec.horizon,
            solver_success=solver["successes"] / solver["attempts"] if solver.get("attempts") else float("nan"),
        ))
    order = {t.id: i for i, t in enumerate(default_catalog())}
    return sorted(rows, key=lambda r: (order[r["task"]], r["control_mode"]))


def plot_stats(rows: list[dict], out: Path) -> Path:
    """Episode length (mean with min-max bars, horizon marked) and solver success per task/mode."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [f"{r['task']}\n{r['control_mode']}" for r in rows]
    x = np.arange(len(rows))
    fig, (ax_len, ax_ok) = plt.subplots(1, 2, figsize=(max(6, 1.6 * len(rows)) * 2, 4))
    mean = np.array([r["mean_len"] for r in rows])
    err = np.array([[r["mean_len"] - r["min_len"] for r in rows], [r["max_len"] - r["mean_len"] for r in rows]])
    ax_len.bar(x, mean, yerr=err, capsize=4, color="tab:blue", label="demo length (mean, min-max)")
    ax_len.scatter(x, [r["horizon"] for r in rows], marker="_", s=600, color="tab:red", label="horizon")
    ax_len.set_ylabel("control steps")
    ax_ok.bar(x, [100 * r["solver_success"] for r in rows], color="tab:green")
    ax_ok.set_ylabel("scripted solver success (%)")
    ax_ok.set_ylim(0, 105)
    for ax in (ax_len, ax_ok):
        ax.set_xticks(x, labels, fontsize=8)
    for xi, r in zip(x, rows):
        ax_ok.text(xi, 100 * r["solver_success"] + 1, f"n={r['demos']}", ha="center", fontsize=8)
    ax_len.legend(fontsize=8)
    fig.suptitle("ManiLadder demonstrations")
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out
