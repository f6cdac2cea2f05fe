#!/usr/bin/env bash
# Why do sync-cut and sync-wait stay at -150 on Tool Delivery (results/tables.md)? Two probes,
# also applied to async for a fair comparison,
# one seed each, resumable (a finished run is skipped): more exploration (entropy 0.05 instead
# of 0.01), and masking the options that cannot succeed (passes with nothing staged, searches
# for found tools), which removes most of the -10s a random sync policy collects.
# Run from the repository root: bash results/investigate_sync.sh
set -euo pipefail
PY=.venv/bin/python
ROOT=results/investigation/tool_delivery
for method in sync-cut sync-wait async; do
  $PY -m train --task tool_delivery --method "$method" --seed 0 --resume progress=false \
    video=false ppo.ent_coef=0.05 --run-dir "$ROOT/$method-ent0.05/seed0"
  $PY -m train --task tool_delivery --method "$method" --seed 0 --resume progress=false \
    video=false env.mask_options=true --run-dir "$ROOT/$method-masked/seed0"
done
# One table per probe (runs are grouped by method, so each probe is its own root).
{
  echo "# Tool Delivery probes: sync-cut, sync-wait and async with more exploration or masking"
  for probe in "$ROOT"/*/; do
    echo
    echo "## $(basename "$probe")"
    echo
    $PY -m eval table "$probe" --threshold tool_delivery=200 | sed 's/^## /### /'
  done
} > results/investigation/tables.md
echo "wrote results/investigation/tables.md"
