#!/usr/bin/env bash
# Create (or refresh) the project's virtual environment in .venv and check headless rendering.
# Idempotent: a second run with unchanged requirements only re-checks EGL (a few seconds).
# MAOPG_EXTRAS names the optional extras to install besides the core (default: dev; the test
# command adds ray, wandb and docs, so the Ray backend's and the W&B logger's tests run and the
# documentation site is built).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
VENV=.venv
EXTRAS=${MAOPG_EXTRAS:-dev}
STAMP=$VENV/.maopg-installed
want=$( (cat pyproject.toml setup.py MANIFEST.in requirements/constraints.txt; echo "$EXTRAS") \
  | sha256sum | cut -d' ' -f1)

if [ ! -x "$VENV/bin/python" ]; then
  echo "[setup] creating $VENV with $($PY --version)"
  "$PY" -m venv "$VENV"
fi
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$want" ]; then
  echo "[setup] installing pinned requirements (requirements/constraints.txt), extras: $EXTRAS"
  "$VENV/bin/python" -m pip install -q --upgrade pip
  # torch first and exactly pinned: an unpinned torch would pull a multi-GB CUDA build.
  "$VENV/bin/python" -m pip install -q -c requirements/constraints.txt torch
  "$VENV/bin/python" -m pip install -q -c requirements/constraints.txt -e ".[$EXTRAS]"
  echo "$want" > "$STAMP"
else
  echo "[setup] $VENV is up to date"
fi
"$VENV/bin/python" -m maopg.sim.egl_check
