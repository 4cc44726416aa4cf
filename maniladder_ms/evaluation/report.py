"""`maniladder report`: one self-contained HTML page (PNGs embedded as base64, and also written beside
it) of one or more results folders. The first folder is the baseline A; every other one is compared to
it with up/down deltas (Table 3 style).

Figures: the Table 3 grid (suite means, levels x {rigid, deformable} x {SG, SX, DG, DX}), level means
with bootstrap intervals against the thresholds, per-task success sorted by level (seed Figure 4), and
success against the task properties T (horizon), C_geom, C_proc, C_perc (seed Figure 7).
"""

from __future__ import annotations

import base64
import html
import io
import time
from pathlib import Path

import numpy as np

from maniladder_ms.catalog import EMBODIMENTS, LEVELS, OBJECT_PROPERTIES, SCORE_KEYS, default_catalog

from . import PROTOCOL_VERSION
from .policies import policy_label
from .results import ResultsError, find_result_dirs, load_results, run_cameras
from .stats import grid, summarize

LEVEL_COLORS = {1: "#4c9f70", 2: "#e0a030", 3: "#d0603a", 4: "#8a3a8f"}
RUN_COLORS = ["#3b6fb6", "#d1495b", "#66a182", "#edae49", "#8d6cab", "#00798c"]


def load_runs(paths) -> list[dict]:
    """[{"name", "dir", "manifest", "summary"}] of the result folders among `paths` (see find_result_dirs)."""
    runs, names = [], set()
    catalog = default_catalog()
    for d in find_result_dirs(paths):
        res = load_results(d)
        if not res["episodes"]:
            continue
        name = policy_label(str(res["manifest"].get("policy", d.name)))
        if name in names:
            name = f"{name} ({d.name})"
        names.add(name)
        summary = summarize(res["episodes"], catalog, skipped=res["manifest"].get("skipped"))
        runs.append({"name": name, "dir": d, "manifest": res["manifest"], "summary": summary})
    if not runs:
        raise ValueError(f"no finished episodes in {', '.join(map(str, paths))}; nothing to report")
    return runs


def check_camera_subsets(runs, mixed_cameras: bool = False) -> None:
    """ResultsError when the runs' policies saw different camera subsets, unless `mixed_cameras` (then the
    subsets stand in the runs table and a warning)."""
    subsets = {run_cameras(run["manifest"]) for run in runs}
    if len(subsets) > 1 and not mixed_cameras:
        each = "; ".join(f"{run['name']} ({run['dir']}): {run_cameras(run['manifest'])}" for run in runs)
        raise ResultsError(f"these runs saw different camera subsets ({each}); their rates are not measured under "
                           "one protocol. Report them apart, or pass --mixed-cameras to compare them with the "
                           "subsets shown")


# ---- figures ------------------------------------------------------------------------------------
def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    _plt().close(fig)
    return buf.getvalue()


def fig_grid(runs) -> bytes:
    plt = _plt()
    cols = [f"{p}\n{e}" for p in OBJECT_PROPERTIES for e in EMBODIMENTS] + ["level\nmean"]
    fig, axes = plt.subplots(len(runs), 1, figsize=(9.5, 2.6 * len(runs) + 0.3), squeeze=False)
    cmap = plt.get_cmap("viridis").copy()
    cmap.set_bad("#eeeeee")
    for ax, run in zip(axes[:, 0], runs):
        rows = grid(run["summary"])
        m = np.array([[np.nan if c["mean"] is None else c["mean"] for c in r["cells"]]
                      + [np.nan if r["level_mean"]["mean"] is None else r["level_mean"]["mean"]] for r in rows])
        ax.imshow(np.ma.masked_invalid(m), cmap=cmap, vmin=0, vmax=1, aspect="auto")
        for i in range(m.shape[0]):
            for j in range(m.shape[1]):
                v = m[i, j]
                ax.text(j, i, "–" if np.isnan(v) else f"{100 * v:.0f}", ha="center", va="center",
                        color="#777" if np.isnan(v) else ("white" if v < 0.55 else "black"), fontsize=10)
        ax.axvline(len(cols) - 1.5, color="white", lw=3)
        ax.set_xticks(range(len(cols)), cols, fontsize=8)
        ax.set_yticks(range(len(LEVELS)), [f"L{lv}" for lv in LEVELS])
        ax.set_title(f"{run['name']}: suite-mean success (%), {run['summary']['ladder']['text'].split(' (')[0]}", fontsize=10)
    fig.tight_layout()
    return _png(fig)


def fig_levels(runs) -> bytes:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 3.4))
    width = 0.8 / len(runs)
    for r, run in enumerate(runs):
        for level in LEVELS:
            lv = run["summary"]["levels"][str(level)]
            if lv["mean"] is None:
                continue
            x = level - 0.4 + width * (r + 0.5)
            err = None
            if lv["ci"]:
                err = [[max(0.0, lv["mean"] - lv["ci"][0])], [max(0.0, lv["ci"][1] - lv["mean"])]]
            ax.bar(x, lv["mean"], width * 0.9, color=RUN_COLORS[r % len(RUN_COLORS)], yerr=err, capsize=3,
                   label=run["name"] if level == min(int(k) for k, v in run["summary"]["levels"].items() if v["mean"] is not None) else None)
    for level in LEVELS:
        t = runs[0]["summary"]["thresholds"][str(level)]
        ax.hlines(t["value"], level - 0.45, level + 0.45, colors="k", linestyles="--", lw=1)
        ax.text(level, t["value"] + 0.02, ("> " if t["strict"] else ">= ") + f"{100 * t['value']:g}%", ha="center", fontsize=8)
    ax.set_xticks(list(LEVELS), [f"L{lv}" for lv in LEVELS])
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("level-mean success")
    ax.set_title("level means (95% bootstrap) vs ladder thresholds", fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return _png(fig)


def _task_order(runs):
    cat = default_catalog()
    ids = {t for run in runs for t in run["summary"]["tasks"]}
    return [t.id for t in sorted(cat, key=lambda t: (t.level, cat.suites().index(t.suite))) if t.id in ids]


def fig_tasks(runs) -> bytes:
    plt = _plt()
    order = _task_order(runs)
    cat = default_catalog()
    fig, ax = plt.subplots(figsize=(max(5.0, 0.55 * len(order) * len(runs) + 2), 3.6))
    width = 0.8 / len(runs)
    for r, run in enumerate(runs):
        for i, tid in enumerate(order):
            t = run["summary"]["tasks"].get(tid)
            if t is None:
                continue
            color = LEVEL_COLORS[t["level"]] if len(runs) == 1 else RUN_COLORS[r % len(RUN_COLORS)]
            err = [[max(0.0, t["rate"] - t["ci"][0])], [max(0.0, t["ci"][1] - t["rate"])]]
            ax.bar(i - 0.4 + width * (r + 0.5), t["rate"], width * 0.9, color=color, yerr=err, capsize=3,
                   label=run["name"] if (len(runs) > 1 and i == next(j for j, x in enumerate(order) if x in run["summary"]["tasks"])) else None)
    levels = [cat.get(t).level for t in order]
    for i in range(1, len(order)):
        if levels[i] != levels[i - 1]:
            ax.axvline(i - 0.5, color="#999", lw=0.8)
    for level in sorted(set(levels)):
        idx = [i for i, lv in enumerate(levels) if lv == level]
        ax.text(np.mean(idx), 1.07, f"L{level}", ha="center", fontsize=9, color=LEVEL_COLORS[level], weight="bold")
    ax.set_xticks(range(len(order)), order, rotation=30, ha="right", fontsize=8)
    ax.set_xlim(-0.6, len(order) - 0.4)
    ax.set_ylim(0, 1.15)
    ax.set_ylabel("success (95% Wilson)")
    ax.set_title("per-task success, sorted by level", fontsize=10)
    if len(runs) > 1:
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return _png(fig)


def fig_properties(runs) -> bytes:
    plt = _plt()
    props = [("horizon", "T (horizon, steps)")] + [(k, k) for k in SCORE_KEYS]
    fig, axes = plt.subplots(1, len(props), figsize=(3.0 * len(props), 3.0), sharey=True)
    rng = np.random.default_rng(0)
    for ax, (key, label) in zip(axes, props):
        for r, run in enumerate(runs):
            ts = list(run["summary"]["tasks"].values())
            if not ts:
                continue
            x = np.array([t["horizon"] if key == "horizon" else t["scores"][key] for t in ts], float)
            unit = 0.015 * max(t["horizon"] for run_ in runs for t in run_["summary"]["tasks"].values()) if key == "horizon" else 0.08
            x = x + (r - (len(runs) - 1) / 2) * unit + rng.uniform(-0.2, 0.2, len(x)) * unit  # runs side by side
            y = np.array([t["rate"] for t in ts])
            err = np.clip(np.array([[t["rate"] - t["ci"][0] for t in ts], [t["ci"][1] - t["rate"] for t in ts]]), 0, None)
            ax.errorbar(x, y, yerr=err, fmt="o", color=RUN_COLORS[r % len(RUN_COLORS)], ms=5, capsize=2, alpha=0.85,
                        label=run["name"])
        ax.set_xlabel(label)
        ax.set_ylim(-0.05, 1.05)
        if key != "horizon":
            ax.set_xlim(0.5, 5.5)
    axes[0].set_ylabel("success")
    axes[-1].legend(fontsize=7, loc="lower right")
    fig.suptitle("success vs task properties", fontsize=10)
    fig.tight_layout()
    return _png(fig)


def fig_deltas(runs) -> bytes:
    plt = _plt()
    base = runs[0]["summary"]["tasks"]
    order = [t for t in _task_order(runs) if t in base]
    fig, ax = plt.subplots(figsize=(max(5.0, 0.55 * len(order) * (len(runs) - 1) + 2), 3.2))
    width = 0.8 / (len(runs) - 1)
    for r, run in enumerate(runs[1:]):
        for i, tid in enumerate(order):
            t = run["summary"]["tasks"].get(tid)
            if t is None:
                continue
            d = t["rate"] - base[tid]["rate"]
            ax.bar(i - 0.4 + width * (r + 0.5), d, width * 0.9, color="#3a9a5b" if d >= 0 else "#c0392b",
                   edgecolor=RUN_COLORS[(r + 1) % len(RUN_COLORS)], lw=2)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(range(len(order)), order, rotation=30, ha="right", fontsize=8)
    ax.set_ylim(-1.05, 1.05)
    ax.set_ylabel(f"success minus {runs[0]['name']}")
    ax.set_title("per-task delta vs the baseline (first folder)", fontsize=10)
    fig.tight_layout()
    return _png(fig)


# ---- HTML ---------------------------------------------------------------------------------------
CSS = """.warn{color:#b71c1c;font-weight:bold}

body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:24px auto;max-width:1100px;color:#222}
h1{font-size:22px} h2{font-size:17px;margin-top:28px;border-bottom:1px solid #ddd;padding-bottom:4px}
table{border-collapse:collapse;margin:8px 0;font-size:13px} th,td{border:1px solid #ccc;padding:3px 7px;text-align:center}
th{background:#f3f3f3} td.l{text-align:left} .na{color:#aaa} .up{color:#1e8449;font-weight:600} .down{color:#c0392b;font-weight:600}
.ladder{font-size:15px;padding:6px 10px;background:#f5f8ff;border-left:4px solid #3b6fb6;margin:6px 0}
img{max-width:100%;border:1px solid #eee;margin:6px 0} .small{font-size:12px;color:#666}
"""


def _e(x) -> str:
    return html.escape(str(x))


def _pct(x) -> str:
    return '<span class="na">–</span>' if x is None else f"{100 * x:.0f}"


def _delta(a, b) -> str:
    if a is None or b is None:
        return ""
    d = 100 * (b - a)
    if abs(d) < 0.5:
        return ' <span class="small">±0</span>'
    return f' <span class="{"up" if d > 0 else "down"}">{"▲" if d > 0 else "▼"}{abs(d):.0f}</span>'


def _grid_html(run, base=None) -> str:
    head = "".join(f"<th>{p}<br>{e}</th>" for p in OBJECT_PROPERTIES for e in EMBODIMENTS)
    out = [f"<table><tr><th>level</th>{head}<th>level mean [95%]</th><th>threshold</th><th>coverage</th></tr>"]
    brows = grid(base["summary"]) if base else None
    for i, row in enumerate(grid(run["summary"])):
        cells = []
        for j, c in enumerate(row["cells"]):
            delta = _delta(brows[i]["cells"][j]["mean"], c["mean"]) if brows else ""
            title = f'{c["suite"]}: {c["n_tasks"]} of {c["catalog_tasks"]} tasks evaluated'
            cells.append(f'<td title="{_e(title)}">{_pct(c["mean"])}{delta}</td>')
        lv = row["level_mean"]
        ci = f' <span class="small">[{_pct(lv["ci"][0])}, {_pct(lv["ci"][1])}]</span>' if lv["ci"] else ""
        delta = _delta(brows[i]["level_mean"]["mean"], lv["mean"]) if brows else ""
        out.append(f'<tr><th>L{row["level"]}</th>{"".join(cells)}<td>{_pct(lv["mean"])}{ci}{delta}</td>'
                   f'<td>{_e(lv["threshold_text"])}</td><td>{lv["n_tasks"]}/{lv["catalog_tasks"]} tasks</td></tr>')
    out.append("</table>")
    return "".join(out)


def _tasks_html(runs) -> str:
    order = _task_order(runs)
    head = "".join(f"<th>{_e(r['name'])}<br><span class='small'>success [95% Wilson] (n)</span></th>" for r in runs)
    out = [f"<table><tr><th>task</th><th>level</th><th>suite</th><th>T</th><th>C_geom/C_proc/C_perc</th>{head}</tr>"]
    cat = default_catalog()
    for tid in order:
        spec = cat.get(tid)
        cells = []
        base = runs[0]["summary"]["tasks"].get(tid)
        for k, run in enumerate(runs):
            t = run["summary"]["tasks"].get(tid)
            if t is None:
                cells.append('<td class="na">–</td>')
                continue
            delta = _delta(base["rate"], t["rate"]) if (k > 0 and base) else ""
            cells.append(f'<td>{100 * t["rate"]:.0f}% <span class="small">[{_pct(t["ci"][0])}, {_pct(t["ci"][1])}] '
                         f'({t["successes"]}/{t["episodes"]})</span>{delta}</td>')
        sc = spec.scores
        out.append(f'<tr><td class="l">{_e(tid)}</td><td>{spec.level}</td><td>{_e(spec.suite)}</td><td>{spec.horizon}</td>'
                   f'<td>{sc["C_geom"]}/{sc["C_proc"]}/{sc["C_perc"]}</td>{"".join(cells)}</tr>')
    out.append("</table>")
    return "".join(out)


def _obs_modes(manifest) -> str:
    """The obs mode(s) episodes ran under: the requested one, or what the policy asked for instead."""
    asked = manifest.get("obs_mode")
    used = sorted({kw.get("obs_mode") for kw in (manifest.get("task_env") or {}).values()} - {None})
    if not used or used == [asked]:
        return str(asked)
    return f"{', '.join(used)} (set by the policy; asked {asked})"


def _runs_html(runs) -> str:
    out = ["<table><tr><th>run</th><th>policy</th><th>obs mode</th><th>cameras</th><th>seed set</th><th>episodes/task</th>"
           "<th>tasks evaluated</th><th>skipped</th><th>episodes</th><th>ladder level</th><th>folder</th></tr>"]
    base_level = runs[0]["summary"]["ladder"]["level"]
    for k, run in enumerate(runs):
        m, s = run["manifest"], run["summary"]
        lad = s["ladder"]
        d = lad["level"] - base_level
        delta = "" if k == 0 or d == 0 else f' <span class="{"up" if d > 0 else "down"}">{"▲" if d > 0 else "▼"}{abs(d)}</span>'
        out.append(
            f'<tr><td class="l"><b>{_e(run["name"])}</b>{" (baseline A)" if k == 0 and len(runs) > 1 else ""}</td>'
            f'<td class="l">{_e(m.get("policy"))}</td><td>{_e(_obs_modes(m))}</td><td>{_e(run_cameras(m))}</td><td>{_e(m.get("seed"))}</td>'
            f'<td>{_e(m.get("episodes"))}</td><td>{s["evaluated_tasks"]}/{s["catalog_tasks"]}</td><td>{len(s["skipped"])}</td>'
            f'<td>{s["episodes"]}</td><td>{"&ge; " if not lad["exact"] else ""}{lad["level"]}{delta}</td>'
            f'<td class="l small">{_e(run["dir"])}</td></tr>')
    out.append("</table>")
    return "".join(out)


def task_set_warnings(runs) -> list[str]:
    """One line per level whose runs evaluated different tasks: their level means are not comparable as they
    stand (random on four tasks against a solver on two others says nothing about either)."""
    out = []
    for level in LEVELS:
        sets = [{t for t, v in run["summary"]["tasks"].items() if v["level"] == level} for run in runs]
        if any(sets) and any(s != sets[0] for s in sets[1:]):
            parts = [f"{run['name']}: {len(s)} task(s)" for run, s in zip(runs, sets)]
            common = set.intersection(*sets)
            out.append(f"L{level} means are over different task sets ({'; '.join(parts)}; {len(common)} in common): "
                       "compare the per-task rows, not the level means")
    return out


def write_report(paths, out=None, title: str = "ManiLadder evaluation report", mixed_cameras: bool = False) -> Path:
    """Write `report.html` and its PNGs into `out` (default <first results folder>/report); returns the HTML path.
    Runs under different camera subsets are refused unless `mixed_cameras` (`check_camera_subsets`)."""
    paths = [Path(p) for p in (paths if isinstance(paths, (list, tuple)) else [paths])]
    runs = load_runs(paths)
    check_camera_subsets(runs, mixed_cameras)
    out = Path(out) if out else runs[0]["dir"] / "report"
    out.mkdir(parents=True, exist_ok=True)
    figures = [("grid", "Table 3: suite-mean success", fig_grid(runs)),
               ("levels", "Level means vs thresholds", fig_levels(runs)),
               ("tasks", "Per-task success sorted by level", fig_tasks(runs)),
               ("properties", "Success vs T, C_geom, C_proc, C_perc", fig_properties(runs))]
    if len(runs) > 1:
        figures.append(("deltas", "Per-task deltas vs the baseline", fig_deltas(runs)))
    imgs = {}
    for key, caption, png in figures:
        (out / f"{key}.png").write_bytes(png)
        imgs[key] = f'<img alt="{_e(caption)}" src="data:image/png;base64,{base64.b64encode(png).decode()}">'

    body = [f"<h1>{_e(title)}</h1>",
            f'<p class="small">generated {time.strftime("%Y-%m-%d %H:%M")} · evaluation protocol v{PROTOCOL_VERSION} · '
            f'{len(runs)} run(s){"; deltas (▲ up / ▼ down, percentage points) are against the first" if len(runs) > 1 else ""}</p>']
    for run in runs:
        body.append(f'<div class="ladder"><b>{_e(run["name"])}</b>: {_e(run["summary"]["ladder"]["text"])}</div>')
    from maniladder_ms.levels import levels_note

    evaluated = sorted({t for run in runs for t in run["summary"]["tasks"]})
    body.append(f'<p class="small">Task levels: {_e(levels_note(default_catalog().get(t) for t in evaluated))}.</p>')
    body += ["<h2>Runs</h2>", _runs_html(runs)]
    body.append("<h2>Table 3: suite-mean success (%)</h2>")
    body.append('<p class="small">Rows: levels; columns: {rigid, deformable} × {SG single-arm gripper, SX single-arm hand, '
                'DG dual-arm gripper, DX dual-arm hand}. A suite mean averages its evaluated tasks; – = no task of the suite '
                'evaluated. A level mean averages the evaluated suites. Ladder level: the highest L such that every level '
                '&le; L clears its threshold; the climb stops at the first level not evaluated (shown as &ge;).</p>')
    for k, run in enumerate(runs):
        body.append(f"<h3>{_e(run['name'])}{' vs ' + _e(runs[0]['name']) if k else ''}</h3>")
        body.append(_grid_html(run, runs[0] if k else None))
    body += [imgs["grid"], "<h2>Level means</h2>", imgs["levels"], "<h2>Per-task success</h2>", imgs["tasks"],
             _tasks_html(runs), "<h2>Success vs task properties</h2>", imgs["properties"]]
    if len(runs) > 1:
        body += ["<h2>Comparison</h2>"]
        body += [f'<p class="warn">{_e(w)}</p>' for w in task_set_warnings(runs)]
        if len({run_cameras(run["manifest"]) for run in runs}) > 1:
            body.append('<p class="warn">The runs saw different camera subsets (runs table, cameras): a delta mixes '
                        'the policies with what they were shown.</p>')
        body.append(imgs["deltas"])
    skipped = {k: v for run in runs for k, v in run["summary"]["skipped"].items()}
    if skipped:
        by_reason: dict = {}
        for k, v in sorted(skipped.items()):
            by_reason.setdefault(v, []).append(k)
        parts = [f"{reason}: {len(ids)} task(s)" + (f" ({', '.join(ids)})" if len(ids) <= 8 else "")
                 for reason, ids in by_reason.items()]
        body.append(f'<p class="small">Not evaluated: {_e("; ".join(parts))}.</p>')
    page = (f'<!DOCTYPE html><html><head><meta charset="utf-8"><title>{_e(title)}</title><style>{CSS}</style></head>'
            f'<body>{"".join(body)}</body></html>')
    path = out / "report.html"
    path.write_text(page, encoding="utf-8")
    return path
