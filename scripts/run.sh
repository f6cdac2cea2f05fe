#!/usr/bin/env bash
# Set up (idempotent) and run the main job: train the paper's method (`async`) on Tool Delivery
# (logs, checkpoints, learning-curve plot, rollout video of the trained policy), then evaluate
# it. Rerunning resumes or, when finished, just re-evaluates. Extra arguments go to `train`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
RUN=${RUN:-runs/tool_delivery/async/seed0}
RESUME=()
if [[ -f "$RUN/config.json" ]]; then RESUME=(--resume); fi  # --resume of no run is an error
.venv/bin/python -m train --task tool_delivery --method async --seed 0 --run-dir "$RUN" \
  "${RESUME[@]}" --total-samples "${SAMPLES:-30000}" "$@"
# Greedy (the task is deterministic, so every greedy episode is the same) and sampled options.
.venv/bin/python -m eval evaluate --checkpoint "$RUN" --episodes 5 --json "$RUN/eval_greedy.json"
.venv/bin/python -m eval evaluate --checkpoint "$RUN" --episodes 20 --sample --json "$RUN/eval.json"
echo "done: $RUN (metrics.csv, tb/, final.pt, learning_curve.png, rollout.mp4, done.json)"
