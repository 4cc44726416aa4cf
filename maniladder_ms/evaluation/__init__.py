"""Evaluation protocol and ladder report: `maniladder eval` and `maniladder report`.

- `policies`: the policy interface, the built-in policies (`random`, `solver`, `replay:<demos>`) and
  loading a user policy from `module:attr` or `path/to/file.py:attr`.
- `runner`: runs episodes under the fixed protocol (evaluation seeds, horizon, success rule, action
  checks), appends one JSON line per finished episode, resumes interrupted runs, process workers.
- `results`: the results folder (manifest with the protocol version, episodes.jsonl, summary.json).
- `stats`: Wilson intervals, suite / level means (Table 3 layout), the ladder level with a bootstrap.
- `report`: the self-contained HTML report with its PNG figures, comparing several result folders.
- `remote`: policies served over a websocket in the openpi protocol (`--policy openpi://HOST:PORT`).
- `serve`: `maniladder serve`, our own server of that protocol for any of our policies.
"""

from __future__ import annotations

PROTOCOL_VERSION = 2
"""Bump when anything that changes the numbers changes (seeds, success rule, obs processing...).
2: every seeded episode starts from fresh physics (order-independent episodes); 1 reused the scene, so an
episode's outcome depended on the episodes run before it in the same process."""

EVAL_SEED_BASE = 1_000_000
"""Evaluation seeds start here; demonstration seeds must stay below it (disjoint by construction)."""
EVAL_SEED_STRIDE = 10_000
"""Seeds of `--seed s`: EVAL_SEED_BASE + s * EVAL_SEED_STRIDE + k for episode k < EVAL_SEED_STRIDE."""


def eval_seed(base_seed: int, episode: int) -> int:
    """The env seed of evaluation episode `episode` (0-based) under `--seed base_seed`; the same for every task."""
    if not 0 <= episode < EVAL_SEED_STRIDE:
        raise ValueError(f"episode index {episode} out of range [0, {EVAL_SEED_STRIDE})")
    if base_seed < 0:
        raise ValueError(f"--seed must be >= 0, got {base_seed}")
    return EVAL_SEED_BASE + base_seed * EVAL_SEED_STRIDE + episode


from .policies import PolicyError, load_policy  # noqa: E402
from .results import ResultsError, load_results  # noqa: E402
from .runner import evaluate  # noqa: E402
from .stats import summarize, wilson_interval  # noqa: E402

__all__ = [
    "PROTOCOL_VERSION", "EVAL_SEED_BASE", "eval_seed", "PolicyError", "load_policy", "ResultsError",
    "load_results", "evaluate", "summarize", "wilson_interval",
]
