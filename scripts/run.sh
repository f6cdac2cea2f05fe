#!/usr/bin/env bash
# Set up (idempotent) and run the main job: train the paper's method (`async`) on Tool Delivery,
# then evaluate the trained policy and render a rollout video. Extra arguments go to `train`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
RUN=${RUN:-runs/tool_delivery/async/seed0}
.venv/bin/python -m train --task tool_delivery --method async --seed 0 --run-dir "$RUN" \
  --total-samples "${SAMPLES:-30000}" "$@"
.venv/bin/python -m eval evaluate "$RUN" --episodes 20
.venv/bin/python -m eval video "$RUN" --out "$RUN/rollout.mp4"
echo "done: $RUN (metrics.csv, tb/, final.pt, learning_curve.png, rollout.mp4)"
