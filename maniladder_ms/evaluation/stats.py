"""Statistics of an evaluation run: per task, per suite (Table 3 layout), per level, the ladder level.

- Task success rate = successes / episodes, with a 95% Wilson score interval.
- Suite mean = mean of the success rates of the suite's *evaluated* tasks; level mean = mean of the
  suite means of the level's evaluated suites (every suite weighs the same, as in Table 3). Tasks that
  were not evaluated (not implemented yet, skipped by the policy, outside the selection) are left out
  and shown as coverage ("k of n tasks"), never counted as failures.
- Thresholds come from the catalog's calibration intervals (`levels.*.success_range`): a level is
  cleared when its level mean is >= the interval's lower edge, or > 0 where that edge is 0 (a rate of
  >= 0 would be vacuous). So L1 >= 60 %, L2 >= 20 %, L3 > 0 %, L4 > 0 % (L4's calibration interval is
  the point 0: the reference policy solves nothing there, so any success at L4 clears it).
- Ladder level = the highest L such that every level <= L is cleared (0 if L1 is not). The climb stops
  at the first level that was not evaluated; the result is then a lower bound (`exact: false`, shown as
  ">= L"). With missing levels below an evaluated one, nothing is claimed about the higher one.
- Uncertainty: a parametric bootstrap over episodes (each task's success count redrawn from
  Binomial(n, p_hat), 2000 draws, fixed rng seed) gives 95% percentile intervals of the suite and level
  means and the distribution of the ladder level (its 2.5-97.5 % range and P(level = L)).
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Optional

import numpy as np

from maniladder_ms.catalog import EMBODIMENTS, LEVELS, OBJECT_PROPERTIES, default_catalog, suite_name

Z95 = 1.959963984540054
EPS = 1e-9


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion (95% by default); (0, 1) for n = 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo, hi = max(0.0, centre - half), min(1.0, centre + half)
    return (0.0 if successes == 0 else min(lo, p)), (1.0 if successes == n else max(hi, p))


def level_thresholds(catalog=None) -> dict[int, dict]:
    """{level: {"value", "strict"}}: cleared iff mean > value (strict) or mean >= value."""
    catalog = catalog or default_catalog()
    out = {}
    for level in LEVELS:
        low = float(catalog.level_success_ranges[level][0])
        out[level] = {"value": low, "strict": low <= 0.0}
    return out


def threshold_text(t: dict) -> str:
    return f"{'>' if t['strict'] else '>='} {t['value'] * 100:g}%"


def clears(mean, t: dict):
    """Whether mean(s) clear threshold `t` (works on floats and numpy arrays)."""
    return mean > t["value"] + EPS if t["strict"] else mean >= t["value"] - EPS


def ladder_level(level_means: dict, thresholds: dict) -> tuple[int, bool]:
    """(ladder level, exact) from {level: mean or None}; see the module doc."""
    reached = 0
    for level in LEVELS:
        mean = level_means.get(level)
        if mean is None:
            return reached, False
        if not clears(mean, thresholds[level]):
            return reached, True
        reached = level
    return reached, True


def summarize(episodes: list[dict], catalog=None, bootstrap: int = 2000, rng_seed: int = 0, skipped: Optional[dict] = None) -> dict:
    """Statistics of a run's episode records (see the module doc); JSON-serialisable."""
    catalog = catalog or default_catalog()
    thresholds = level_thresholds(catalog)
    per_task = defaultdict(list)
    for rec in episodes:
        per_task[rec["task"]].append(rec)
    tasks = {}
    for spec in catalog:  # catalog order: level, suite
        recs = per_task.get(spec.id)
        if not recs:
            continue
        n = len(recs)
        s = sum(bool(r["success"]) for r in recs)
        lo, hi = wilson_interval(s, n)
        tasks[spec.id] = {
            "level": spec.level, "suite": spec.suite, "object_property": spec.object_property,
            "embodiment": spec.embodiment, "horizon": spec.horizon, "scores": dict(spec.scores),
            "episodes": n, "successes": s, "rate": s / n, "ci": [lo, hi],
            "mean_steps": float(np.mean([r["steps"] for r in recs])),
            "mean_wall_s": float(np.mean([r.get("wall_s", 0.0) for r in recs])),
            # episodes whose simulation went non-finite (failures; `runner.simulation_diverged`)
            "diverged": sum(bool(r.get("diverged")) for r in recs),
            # how far the episodes got: the share that reached each intermediate flag (records that carry them)
            "reached": {flag: sum(flag in r["reached"] for r in recs if "reached" in r) / n
                        for flag in sorted({f for r in recs for f in r.get("reached", ())})},
        }
    unknown = sorted(set(per_task) - set(tasks))
    if unknown:
        raise ValueError(f"episode records of tasks not in the catalog: {', '.join(unknown)}")

    ids = list(tasks)
    suites_all = catalog.suites()
    present_suites = [s for s in suites_all if any(tasks[t]["suite"] == s for t in ids)]
    rates = np.array([tasks[t]["rate"] for t in ids])
    ns = np.array([tasks[t]["episodes"] for t in ids])

    def aggregate(r):
        """suite means (.., n_suites) and level means {level: (..) or None} of task rates r (.., n_tasks)."""
        sm = np.stack([r[..., [i for i, t in enumerate(ids) if tasks[t]["suite"] == s]].mean(-1) for s in present_suites], -1) if present_suites else None
        lm = {}
        for level in LEVELS:
            cols = [j for j, s in enumerate(present_suites) if s.startswith(f"L{level}-")]
            lm[level] = sm[..., cols].mean(-1) if cols else None
        return sm, lm

    suite_means, level_means = aggregate(rates)
    point_ladder, exact = ladder_level({k: (None if v is None else float(v)) for k, v in level_means.items()}, thresholds)

    boot = {}
    if bootstrap and ids:
        rng = np.random.default_rng(rng_seed)
        draws = rng.binomial(ns, rates, size=(bootstrap, len(ids))) / ns
        b_suite, b_level = aggregate(draws)
        b_ladder = np.zeros(bootstrap, dtype=int)
        alive = np.ones(bootstrap, dtype=bool)
        for level in LEVELS:
            if b_level[level] is None:
                break
            alive &= clears(b_level[level], thresholds[level])
            b_ladder[alive] = level
        boot = {"suite": b_suite, "level": b_level, "ladder": b_ladder}

    def pct(a):
        return [float(np.percentile(a, 2.5)), float(np.percentile(a, 97.5))]

    suites = {}
    for j, s in enumerate(suites_all):
        level, prop, emb = s.split("-")
        members = [t for t in ids if tasks[t]["suite"] == s]
        entry = {"level": int(level[1:]), "object_property": prop, "embodiment": emb,
                 "catalog_tasks": sum(t.suite == s for t in catalog), "n_tasks": len(members), "tasks": members,
                 "mean": None, "ci": None}
        if members:
            k = present_suites.index(s)
            entry["mean"] = float(suite_means[k])
            entry["ci"] = pct(boot["suite"][:, k]) if boot else None
        suites[s] = entry

    levels = {}
    for level in LEVELS:
        m = level_means[level]
        levels[str(level)] = {
            "mean": None if m is None else float(m),
            "ci": pct(boot["level"][level]) if (boot and m is not None) else None,
            "n_suites": sum(1 for s in present_suites if s.startswith(f"L{level}-")),
            "n_tasks": sum(1 for t in ids if tasks[t]["level"] == level),
            "catalog_tasks": sum(1 for t in catalog if t.level == level),
            "threshold": thresholds[level], "threshold_text": threshold_text(thresholds[level]),
            "clears": None if m is None else bool(clears(float(m), thresholds[level])),
        }

    ladder = {"level": point_ladder, "exact": exact}
    if boot:
        lad = boot["ladder"]
        ladder["ci"] = [int(np.percentile(lad, 2.5, method="lower")), int(np.percentile(lad, 97.5, method="higher"))]
        ladder["probabilities"] = {str(L): float(np.mean(lad == L)) for L in range(0, 5)}
    ladder["text"] = ladder_text(ladder, levels)

    return {
        "tasks": tasks, "suites": suites, "levels": levels, "ladder": ladder,
        "thresholds": {str(k): v for k, v in thresholds.items()},
        "episodes": int(ns.sum()) if ids else 0,
        "catalog_tasks": len(catalog), "evaluated_tasks": len(ids), "skipped": dict(skipped or {}),
        "bootstrap": {"draws": int(bootstrap), "rng_seed": rng_seed},
    }


def ladder_text(ladder: dict, levels: dict) -> str:
    L = ladder["level"]
    head = f"ladder level {'>= ' if not ladder['exact'] else ''}{L}"
    parts = []
    if ladder.get("ci"):
        lo, hi = ladder["ci"]
        p = ladder["probabilities"].get(str(L), 0.0)
        parts.append(f"95% bootstrap range {lo}-{hi}, P(level = {L}) = {p:.2f}" if lo != hi else f"95% bootstrap range {lo}-{hi}")
    if not ladder["exact"]:
        missing = next((lv for lv in LEVELS if levels[str(lv)]["mean"] is None), None)
        if missing is not None:
            parts.append(f"level {missing} not evaluated, so this is a lower bound")
    return head + (f" ({'; '.join(parts)})" if parts else "")


def grid(summary: dict) -> list[dict]:
    """Table 3 rows: [{"level", "cells": [{suite, mean, ci, n_tasks, catalog_tasks}] * 8, "level_mean"}]."""
    rows = []
    for level in LEVELS:
        cells = [dict(summary["suites"][suite_name(level, p, e)], suite=suite_name(level, p, e))
                 for p in OBJECT_PROPERTIES for e in EMBODIMENTS]
        rows.append({"level": level, "cells": cells, "level_mean": summary["levels"][str(level)]})
    return rows
