#!/usr/bin/env bash
# Set up (idempotent, with the optional Ray and W&B extras: their backend and logger are tested
# too) and run the whole test suite plus lint. CI runs exactly this (.ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."
MAOPG_EXTRAS=dev,ray,wandb bash scripts/setup.sh
.venv/bin/ruff format --check .
.venv/bin/ruff check .
# One test process per core (pytest-xdist); the Ray tests stay together on one of them.
.venv/bin/python -m pytest -n auto --dist loadgroup "$@"
