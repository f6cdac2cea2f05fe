"""Mac-DQN vs async on Tool Delivery (the paper's Table I): samples to threshold and peak.

Run: ``.venv/bin/python bench/analysis/macdqn_vs_async.py [--runs results/runs]
[--seeds 0 1 2 3 4]``.
Brings both methods' runs to completion through the reproduction grid's runner (finished runs
are read, unfinished ones resume; both get the same budget in low-level samples) and prints the
peak and samples-to-threshold tables the results use. The threshold is the one used for async
(a mean episode return of 200). Paper: Mac-DQN needed 3–8x more samples than async.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.studies.grid import log_to_stderr, run_grid
from maopg.experiment.studies.runs import discover_runs
from maopg.experiment.studies.tables import peak_table, threshold_table

TASK, METHODS = "tool_delivery", ("async", "mac-dqn")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=Path("results/runs"))
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--threshold", type=float, default=200.0)
    parser.add_argument("--window", type=int, default=5, help="iterations smoothed")
    args = parser.parse_args()

    run_grid(args.runs, tasks=[TASK], methods=METHODS, seeds=args.seeds, log=log_to_stderr)
    runs = [
        r for r in discover_runs([args.runs / TASK]) if r.method in METHODS and r.seed in args.seeds
    ]
    print("### Mac-DQN vs async on Tool Delivery (`bench/analysis/macdqn_vs_async.py`)\n")
    print(markdown(gl=False))
    print(f"- seeds {args.seeds}, runs in `{args.runs}/{TASK}/`, window {args.window}\n")
    print(peak_table(runs, window=args.window, methods=METHODS))
    print()
    print(threshold_table(runs, {TASK: args.threshold}, window=args.window, methods=METHODS))


if __name__ == "__main__":
    main()
