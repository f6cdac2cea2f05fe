#!/usr/bin/env bash
# Is Water Filling's Mac-DQN behind async (results/tables.md, Table I analog) because of the
# reward scale? Its Huber δ (10) and gradient clip (10) were chosen for Tool Delivery's ±100
# rewards, while Water Filling charges ~-10^3 per tick and Mac-DQN, unlike MAPPO, has no value
# normalisation. The probe scales the rewards Mac-DQN learns from by 1e-3 (dqn.reward_scale),
# everything else as in the grid (same seeds, 10K replay). Resumable: a finished run is skipped.
# Run from the repository root: bash results/investigate_macdqn.sh [SEED ...] (default 0 1 2)
set -euo pipefail
PY=.venv/bin/python
ROOT=results/investigation/water_filling/mac-dqn-rscale1e-3
seeds=("$@")
[ ${#seeds[@]} -gt 0 ] || seeds=(0 1 2)
for seed in "${seeds[@]}"; do
  $PY -m train --task water_filling --method mac-dqn --seed "$seed" --resume progress=false \
    video=false dqn.buffer_size=10000 dqn.reward_scale=0.001 --run-dir "$ROOT/seed$seed"
done
{
  echo "# Water Filling probe: Mac-DQN with rewards scaled by 1e-3"
  echo
  echo "Compare with Mac-DQN and async in [../tables.md](../tables.md)."
  echo
  $PY -m eval table "$ROOT" | sed 's/^## /### /'
} > results/investigation/macdqn_water_filling.md
echo "wrote results/investigation/macdqn_water_filling.md"
