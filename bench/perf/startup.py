"""Fixed start-up costs, old vs new checkout side by side: the wall-clock of
``import maopg.experiment.training.trainer`` and of a short Tool Delivery training command.

Run: ``.venv/bin/python bench/perf/startup.py [--ref 4e53a18] [--rounds N]``. Prints a
Markdown block for BENCHMARKS.md (progress goes to stderr).

A short run is mostly start-up: importing torch and MuJoCo, building the environments and the
networks, and after training the learning-curve plot. Every test and smoke run pays it, so this
measures it as a user sees it: each figure is the wall-clock of a fresh interpreter running the
command, from process start to exit. The checkouts and the alternation are
``bench/perf/compare_checkouts.py``'s (old = ``git archive REF``, new = a snapshot of the working
tree; old first in odd rounds, new first in even ones, every run a fresh subprocess whose
``maopg`` imports are checked to come from its own checkout), so are the verdicts (*noise* when
the old and new min–max ranges overlap). One untimed import per side first compiles its
``.pyc`` files, which the fresh snapshots lack, so no round pays for that.

Measured:

- importing the trainer module, ``maopg.experiment.training.trainer`` (``maopg.experiment.trainer``
  in a checkout before the split into packages; what ``python -m train`` imports before it parses);
- ``python -m train --task tool_delivery --method async --total-samples 400 video=false
  progress=false``, the same command on both sides (the new side still draws the learning
  curve, as a user's run does);
- the new side with ``plot=false`` as well (what the tests' short runs pass), against the old
  side's same command: what a test's training run paid before and pays now.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

from compare_checkouts import (
    REPO,
    Checkout,
    Column,
    Figure,
    checkouts,
    markdown,
    run_script,
)

DEFAULT_REF = "4e53a18"
TRAIN = (
    "--task",
    "tool_delivery",
    "--method",
    "async",
    "--total-samples",
    "400",
    "video=false",
    "progress=false",
)
IMPORT = (
    "import importlib, importlib.util\n"
    "new = importlib.util.find_spec('maopg.experiment.training') is not None\n"
    "importlib.import_module('maopg.experiment.' + ('training.trainer' if new else 'trainer'))\n"
)
"""Imports the trainer module where each checkout has it (``experiment/trainer.py`` before the
split into packages)."""


def timed(
    checkout: Checkout, script: Path, args: tuple[str, ...], others: list[Path], cwd: Path
) -> dict[str, float]:
    """Wall-clock and CPU seconds (user + sys, all threads) of one fresh interpreter running
    ``script args``. The CPU time is the steadier figure on a loaded machine: waiting for a
    core lengthens the wall-clock but not it (the runs are sequential, so the children's
    ``getrusage`` delta is this one child's)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    run_script(checkout, script, args, others, cwd)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ref", default=DEFAULT_REF, help="the old commit (default: %(default)s)")
    parser.add_argument("--rounds", type=int, default=6, help="old/new pairs per measurement")
    args = parser.parse_args()
    if args.rounds < 2:
        parser.error("--rounds must be at least 2: the verdicts compare the rounds' spread")
    started = time.perf_counter()
    conditions = markdown()  # before anything runs: its load average is the one at start
    labels = {
        "import": "`import` of the trainer module (s)",
        "train": "`python -m train ...` as above (s)",
        "train, plot=false": "the same, new side with `plot=false` (s)",
    }
    clocks = ("wall", "cpu")
    figures = {
        (key, clock): Figure(Column(label, ())) for key, label in labels.items() for clock in clocks
    }
    loads: list[float] = []
    with tempfile.TemporaryDirectory(prefix="maopg-startup-") as tmp:
        work = Path(tmp)
        old, new, cwd = checkouts(args.ref, work)
        importer = cwd / "import_trainer.py"
        importer.write_text(IMPORT)
        for checkout in (old, new):  # untimed: compiles each side's .pyc files once
            print(f"warm-up: {checkout.side}", file=sys.stderr)
            run_script(checkout, importer, (), [], cwd)
        for round_ in range(args.rounds):
            pair = ((old, new), (new, old))
            for checkout, other in pair if round_ % 2 == 0 else pair[::-1]:
                others = [other.root, REPO]  # the repository itself is the editable install
                train = checkout.root / "train" / "__main__.py"
                run_dir = ("--run-dir", str(work / f"run-{checkout.side}"), "--overwrite")
                cases = [("import", importer, ()), ("train", train, (*TRAIN, *run_dir))]
                if checkout.side == "new":
                    cases.append(("train, plot=false", train, (*TRAIN, "plot=false", *run_dir)))
                for key, script, extra in cases:
                    print(
                        f"round {round_ + 1}/{args.rounds}: {checkout.side} {key}", file=sys.stderr
                    )
                    loads.append(os.getloadavg()[0])
                    for clock, seconds in timed(checkout, script, extra, others, cwd).items():
                        cell = f"{seconds:.2f}"
                        figures[key, clock].cells[checkout.side].append(cell)
                        if key == "train" and checkout.side == "old":
                            # The old code has no plot setting: its one command is both baselines.
                            figures["train, plot=false", clock].cells["old"].append(cell)
    elapsed = time.perf_counter() - started

    print("### Start-up of a short run, old vs new (`bench/perf/startup.py`)\n")
    print(conditions)
    print(f"- load average (1 min) before each run: {min(loads):.2f}–{max(loads):.2f}")
    print(f"- load average (1 min) at end: {os.getloadavg()[0]:.2f}")
    if min(loads) >= 1.0:
        print(
            "- other processes were running throughout (load average never below 1 on "
            f"{os.cpu_count()} CPUs): the wall-clock figures are inflated and noisy, the CPU "
            "times much less so"
        )
    print(f"- old: {old.description}; maopg imported from `{old.maopg_file}`")
    print(f"- new: {new.description}; maopg imported from `{new.maopg_file}`")
    print(f"- training command: `python -m train {' '.join(TRAIN)} --run-dir DIR --overwrite`")
    print(
        f"- {args.rounds} rounds, each side's commands back to back in fresh interpreters, old "
        f"first in odd rounds and new first in even ones; *wall* = wall-clock from process "
        f"start to exit, *cpu* = its user + sys CPU time; median (min–max); total wall time "
        f"{elapsed / 60:.1f} min\n"
    )
    print("| measurement | clock | old | new | new/old | verdict |")
    print("|---|---|---|---|---|---|")
    for (_, clock), figure in figures.items():
        print(
            f"| {figure.column.header} | {clock} | {figure.show('old')} | {figure.show('new')} | "
            f"{figure.ratio():.3f} | {figure.verdict()} |"
        )
    cpu = {key: statistics.median(f.values("new")) for (key, c), f in figures.items() if c == "cpu"}
    print(
        f"\nIn CPU time, of the new short run's {cpu['train']:.2f} s, "
        f"{cpu['import']:.2f} s is the import of the trainer (torch, MuJoCo) and "
        f"{cpu['train'] - cpu['train, plot=false']:.2f} s the learning-curve plot."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
