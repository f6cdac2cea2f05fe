#!/usr/bin/env bash
# Create (or refresh) the project's virtual environment in .venv and check headless rendering.
# Idempotent: a second run with unchanged requirements only re-checks EGL (a few seconds).
# MAOPG_EXTRAS names the optional extras to install besides the core: none by default, which is
# all the main job (scripts/run.sh) needs; the test command asks for dev,ray,wandb,docs. Extras
# installed once stay installed (and are kept up to date), so the two commands can alternate
# without reinstalling.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
VENV=.venv
STAMP=$VENV/.maopg-installed
want=$(cat pyproject.toml setup.py MANIFEST.in requirements/constraints.txt | sha256sum | cut -d' ' -f1)
have="" had=""
if [ -f "$STAMP" ]; then read -r have had < "$STAMP" || true; fi
# The extras asked for and those installed before, one comma-separated sorted list.
extras=$(echo "${MAOPG_EXTRAS:-},$had" | tr -d ' ' | tr ',' '\n' | sed '/^$/d' | sort -u | paste -sd, -)

if [ ! -x "$VENV/bin/python" ]; then
  echo "[setup] creating $VENV with $($PY --version)"
  "$PY" -m venv "$VENV"
  have=""
fi
if [ "$have" != "$want" ] || [ "$extras" != "$had" ]; then
  echo "[setup] installing pinned requirements (requirements/constraints.txt), extras: ${extras:-none}"
  "$VENV/bin/python" -m pip install -q --upgrade pip
  # torch first and exactly pinned: an unpinned torch would pull a multi-GB CUDA build.
  "$VENV/bin/python" -m pip install -q -c requirements/constraints.txt torch
  "$VENV/bin/python" -m pip install -q -c requirements/constraints.txt -e ".${extras:+[$extras]}"
  echo "$want $extras" > "$STAMP"
else
  echo "[setup] $VENV is up to date (extras: ${extras:-none})"
fi
"$VENV/bin/python" -m maopg.sim.egl_check
