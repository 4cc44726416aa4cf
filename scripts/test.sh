#!/usr/bin/env bash
# The test command: everything except the long sweeps, plus a sample of them (marker `sample`).
# Full sweeps: .venv/bin/python -m pytest -m slow
# Two pytest workers (pytest-xdist): the simulation is single-threaded, and two PhysX CPU processes each keep ~85 %
# of one alone on a 2-core machine (../shared/notes/measured-facts.md). MANILADDER_TEST_WORKERS=0 runs in-process.
set -euo pipefail
cd "$(dirname "$0")/.."
exec .venv/bin/python -m pytest -m "not slow or sample" -n "${MANILADDER_TEST_WORKERS:-2}" --dist loadgroup --durations=30 "$@"
