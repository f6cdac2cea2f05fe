"""Training-loop throughput: samples per second of ``python -m train`` with its defaults.

Run: ``.venv/bin/python bench/perf/train_rate.py [--cases td-rgb,wf-rgb]``. Prints a Markdown table.
Each case trains ``async`` from RGB cameras through the command line, exactly as a user would
(default backend, batch size and network; ``video=false``), in a scratch run directory, and
reads the rate from the run's own ``metrics.csv``: samples over wall-clock of every iteration
but the first (warm-up: lazy imports, first renders, allocator growth).

The script uses nothing but the command line and ``metrics.csv``, which every version of the
project has, so ``bench/perf/compare_checkouts.py --sections train`` runs *this* script against an
old checkout and the new tree alike (issue 16's "≥ 2× today's" is read from that comparison).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import runpy
import sys
import tempfile
import time
from pathlib import Path

CASES = {
    "td-rgb": ("tool_delivery", ["--images", "--total-samples", "3000"]),
    "wf-rgb": ("water_filling", ["--images", "--total-samples", "6000"]),
}
"""Case → (task, arguments): 15 iterations of Tool Delivery's 200-tick batches, 3 of Water
Filling's 2,000-tick ones."""


def train_rate(
    task: str, args: list[str], run_dir: Path, method: str = "async"
) -> tuple[float, int]:
    """(samples/s after the first iteration, iterations) of one run of the command line."""
    argv = ["train", "--task", task, "--method", method, *args, "--run-dir", str(run_dir)]
    sys.argv = [*argv, "video=false", "progress=false"]
    try:  # the command's own output (its run directory) would split the table: to stderr
        with contextlib.redirect_stdout(sys.stderr):
            runpy.run_module("train", run_name="__main__", alter_sys=True)
    except SystemExit as stop:
        if stop.code not in (0, None):
            raise
    with (run_dir / "metrics.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    first, last = rows[0], rows[-1]
    samples = float(last["samples"]) - float(first["samples"])
    seconds = float(last["wall_time"]) - float(first["wall_time"])
    return samples / seconds, len(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated: %(default)s")
    options = parser.parse_args()
    print("| case | task | iterations | train samples/s | wall-clock (s) |")
    print("|---|---|---|---|---|")
    for case in options.cases.split(","):
        task, args = CASES[case]
        with tempfile.TemporaryDirectory() as scratch:
            start = time.perf_counter()
            rate, iterations = train_rate(task, args, Path(scratch) / "run")
            wall = time.perf_counter() - start
        print(f"| {case} | {task} | {iterations} | {rate:.1f} | {wall:.1f} |")


if __name__ == "__main__":
    main()
