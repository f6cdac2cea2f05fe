#!/usr/bin/env bash
# Set up (idempotent, with the optional Ray and W&B extras: their backend and logger are tested
# too, and the docs extra: the site is built with warnings as errors) and run the whole test
# suite plus lint. CI runs exactly this (.ci/run).
set -euo pipefail
cd "$(dirname "$0")/.."
MAOPG_EXTRAS=dev,ray,wandb,docs bash scripts/setup.sh
.venv/bin/ruff format --check .
.venv/bin/ruff check .
# One test process per core (pytest-xdist), each taking whole test files: a module's fixtures
# (the Ray tests' one Ray instance) stay in one process. (xdist_group marks are not honoured
# with pytest 9.2 and xdist 3.8: measured, the group's tests ran on both workers.) The files
# go out in collection order, files with a slow test first (tests/conftest.py).
.venv/bin/python -m pytest -n auto --dist loadfile --no-loadscope-reorder "$@"
