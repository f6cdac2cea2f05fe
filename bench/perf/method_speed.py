"""Wall time per 100K samples of every method, side by side in one run, on the Box Pushing
grid (6x6) and Tool Delivery from state.

Run: ``.venv/bin/python bench/perf/method_speed.py [--cases bp6,td] [--methods async,acac]
[--samples 20000] [--rounds 2]``. Prints a Markdown block for BENCHMARKS.md.

Each method trains through the command line at its defaults (``video=false``, no evaluation
during training) for ``--samples`` samples in a scratch run directory; its rate is read from
the run's own ``metrics.csv`` as in ``train_rate.py`` (samples over the wall-clock of every
iteration but the first), and a row gives the seconds 100K samples take at that rate. Methods
take turns within each of ``--rounds`` rounds, the order reversed every round, so a change in
the machine's load hits all alike; the figure is the median over rounds (min–max). A method a
task refuses (the product categorical at team size 8, say) is listed with the reason.

The rate depends on what the policy does, not only on its cost: a method whose episodes end
sooner resets more often, and ACAC's and MacroMARL's rounds throw away the episodes that do
not finish in a round, so they simulate more ticks per finished episode. These are maopg's
samples, every simulated tick.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.append(str(Path(__file__).parents[2]))  # `train`, after PYTHONPATH (compare_checkouts)
sys.path.insert(0, str(Path(__file__).parent))  # train_rate
from train_rate import train_rate

from maopg.experiment.run.methods import method_names
from maopg.experiment.run.sysinfo import markdown

CASES = {
    "bp6": ("box_pushing_grid", ["env.size=6"]),
    "td": ("tool_delivery", []),
}
"""Case → (task, settings): the grid at the published runs' size, Tool Delivery from state."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated: %(default)s")
    parser.add_argument("--methods", default=",".join(method_names()), help="comma-separated")
    parser.add_argument("--samples", type=int, default=20_000, help="a run's budget")
    parser.add_argument("--rounds", type=int, default=2)
    options = parser.parse_args()
    methods = options.methods.split(",")
    print(markdown())
    print(
        f"\n{options.samples:,} samples a run, {options.rounds} rounds, median (min–max)\n\n"
        "| case | task | method | s per 100K samples | samples/s |\n|---|---|---|---|---|"
    )
    for case in options.cases.split(","):
        task, settings = CASES[case]
        rates: dict[str, list[float]] = {m: [] for m in methods}
        refused: dict[str, str] = {}
        for r in range(options.rounds):
            for method in methods if r % 2 == 0 else reversed(methods):
                if method in refused:
                    continue
                args = [*settings, "--total-samples", str(options.samples), "eval_every=0"]
                with tempfile.TemporaryDirectory() as scratch:
                    try:
                        rate, _ = train_rate(task, args, Path(scratch) / "run", method)
                    except SystemExit as stop:
                        refused[method] = f"refused (exit {stop.code})"
                        continue
                rates[method].append(rate)
        for method in methods:
            if method in refused:
                print(f"| {case} | {task} | {method} | {refused[method]} | — |")
                continue
            per = [100_000 / rate for rate in rates[method]]
            print(
                f"| {case} | {task} | {method} | {statistics.median(per):.0f} "
                f"({min(per):.0f}–{max(per):.0f}) | {statistics.median(rates[method]):,.0f} |"
            )


if __name__ == "__main__":
    main()
