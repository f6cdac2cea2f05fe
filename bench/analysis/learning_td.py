"""Sample efficiency of `async` on Tool Delivery (state observations) over seeds.

Run: ``.venv/bin/python bench/analysis/learning_td.py [--runs results/runs] [--seeds 0 1 2 3 4]``.
Brings each seed's run to completion with the reproduction grid's runner (a finished run is
read, not retrained; an unfinished one resumes), then prints per seed: the low-level samples at
which the trailing mean episode return first reaches the threshold, the final return, the
paper's metric and the wall-clock, plus the conditions. Target (issue 5): ≥ 200 within 100K
samples on at least 4 of 5 seeds.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.studies.grid import log_to_stderr, run_grid
from maopg.experiment.studies.runs import PAPER_METRIC, RETURN, load_run, samples_to_threshold

TASK, METHOD = "tool_delivery", "async"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, default=Path("results/runs"))
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--threshold", type=float, default=200.0)
    parser.add_argument("--budget", type=float, default=100_000, help="samples for the target")
    parser.add_argument("--window", type=int, default=25, help="iterations (200 ticks each)")
    args = parser.parse_args()

    run_grid(args.runs, tasks=[TASK], methods=[METHOD], seeds=args.seeds, log=log_to_stderr)
    print("### `async` on Tool Delivery, state observations (`bench/analysis/learning_td.py`)\n")
    print(markdown(gl=False))
    print(
        f"- threshold {args.threshold:g} on the trailing mean of {args.window} iterations' "
        f"episode returns; runs in `{args.runs}/{TASK}/{METHOD}/`"
    )
    print(
        "- wall-clock is what each run logged (one torch thread, as `train` defaults to); "
        "other processes may have shared the 2 cores then\n"
    )
    print(
        "| seed | samples to threshold | final return (last 10K) | paper's metric (last 10K) "
        "| samples | wall-clock (s) |"
    )
    print("|---|---|---|---|---|---|")
    hits = 0
    for seed in args.seeds:
        run = load_run(args.runs / TASK / METHOD / f"seed{seed}")
        reach = samples_to_threshold(run, args.threshold, RETURN, args.window)
        hits += not math.isnan(reach) and reach <= args.budget
        last = run.samples >= run.samples[-1] - 10_000
        final = np.nanmean(run.metrics[RETURN][last])
        paper = np.nanmean(run.metrics[PAPER_METRIC][last])
        wall = run.metrics["wall_time"][-1]
        reach_text = "never" if math.isnan(reach) else f"{reach:,.0f}"
        print(
            f"| {seed} | {reach_text} | {final:.1f} | {paper:.2f} | {run.samples[-1]:,.0f} "
            f"| {wall:.0f} |"
        )
    verdict = "met" if hits >= min(4, len(args.seeds)) else "NOT met"
    print(
        f"\n{hits} of {len(args.seeds)} seeds reach {args.threshold:g} within "
        f"{args.budget:,.0f} samples: target {verdict}."
    )


if __name__ == "__main__":
    main()
