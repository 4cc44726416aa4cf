#!/usr/bin/env bash
# The test command: everything except the long sweeps, plus a sample of them (marker `sample`).
# Full sweeps: .venv/bin/python -m pytest -m slow
set -euo pipefail
cd "$(dirname "$0")/.."
exec .venv/bin/python -m pytest -m "not slow or sample" --durations=20 "$@"
