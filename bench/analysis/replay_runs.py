"""Does a change leave training as it was? Train committed runs' configs again with each version
of the code, on one machine, and compare the curves row for row.

Run, for a change that claims to leave behaviour alone (``OLD`` a checkout of the code before
it, e.g. ``git worktree add /tmp/old <commit>``)::

    PYTHONPATH=OLD .venv/bin/python OLD/bench/analysis/replay_runs.py train RUNS --out /tmp/before
    .venv/bin/python bench/analysis/replay_runs.py train RUNS --out /tmp/after
    .venv/bin/python bench/analysis/replay_runs.py compare /tmp/before /tmp/after

(each side runs its own copy of this script, which imports its own version's modules);
``train`` trains each of the run directories ``RUNS``' saved ``config.json`` afresh into
``--out`` (under the run's ``task/method/seedN``), its budget cut to ``--samples`` (0: the
whole budget);
``compare`` prints one line per run — ``identical`` over how many rows, or the first row and the
columns that differ — comparing every column both sides log but the machine's timings (a column
one side adds, as a new metric, is named, not compared), and exits 1 if any differs. Curves are
bit-exact per machine and thread count, not across machines, so both sides must train on the
same one (a committed run trained elsewhere is no reference). Only what a run's budget does not
steer is comparable on a shorter budget (an entropy bonus annealed over the whole run,
``ppo.ent_decay``, is steered; the committed grid anneals nothing).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import sys
from pathlib import Path

from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import CONFIG, METRICS, TIMING_COLUMNS
from maopg.experiment.training.trainer import train


def rows(run_dir: Path) -> list[dict[str, str]]:
    """The run's ``metrics.csv`` rows without the machine's timings."""
    with (run_dir / METRICS).open() as handle:
        return [
            {k: v for k, v in row.items() if k not in TIMING_COLUMNS}
            for row in csv.DictReader(handle)
        ]


def train_again(run_dir: Path, samples: int, out: Path) -> Path:
    """Train ``run_dir``'s saved config afresh into ``out/<task>/<method>/seed<seed>``."""
    saved = TrainConfig.load(run_dir / CONFIG)
    target = out / saved.task / saved.method / f"seed{saved.seed}"
    config = dataclasses.replace(
        saved,
        total_samples=samples or saved.total_samples,
        run_dir=str(target),
        progress=False,
        video=False,
        plot=False,
        eval_episodes=0,
        logger="tensorboard",
    )
    train(config)
    return target


def compare(before: Path, after: Path) -> tuple[str, bool]:
    """A line on whether ``after``'s curve repeats ``before``'s, and whether it differs."""
    return compare_rows(rows(before), rows(after))


def compare_rows(old: list[dict[str, str]], new: list[dict[str, str]]) -> tuple[str, bool]:
    """A line on whether the ``new`` rows repeat the ``old`` ones (every column both log but
    the machine's timings), and whether they differ."""
    if not old or not new:
        return f"DIFFERS: {len(old)} rows before, {len(new)} after", True
    shared = old[0].keys() & new[0].keys()
    for i, (a, b) in enumerate(zip(old, new, strict=False)):
        columns = sorted(k for k in shared if a[k] != b[k])
        if columns:
            return f"DIFFERS at row {i} (samples {a.get('samples')}): {', '.join(columns)}", True
    if len(old) != len(new):
        return f"DIFFERS in length: {len(old)} rows before, {len(new)} after", True
    one_sided = sorted((old[0].keys() | new[0].keys()) - shared)
    logged = f"; logged on one side only: {', '.join(one_sided)}" if one_sided else ""
    return f"identical over {len(old)} rows ({old[-1]['samples']} samples){logged}", False


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("train", help="train run directories' configs afresh")
    p.add_argument("runs", nargs="+", type=Path, help="run directories with a config.json")
    p.add_argument("--samples", type=int, default=20_000, help="budget (0: the run's own)")
    p.add_argument("--out", type=Path, required=True)
    p = sub.add_parser("compare", help="compare two train outputs row for row")
    p.add_argument("before", type=Path)
    p.add_argument("after", type=Path)
    args = parser.parse_args()
    if args.command == "train":
        if args.samples < 0:
            parser.error(f"--samples must be >= 0, got {args.samples}")
        missing = [str(r) for r in args.runs if not (r / CONFIG).exists()]
        if missing:
            parser.error(f"no {CONFIG} in {missing[0]}")
        for run_dir in args.runs:
            print(f"{run_dir}: trained into {train_again(run_dir, args.samples, args.out)}")
        return 0
    runs = sorted(p.parent.relative_to(args.before) for p in args.before.rglob(METRICS))
    if not runs:
        parser.error(f"no {METRICS} under {args.before}")
    differs = False
    for run in runs:
        if not (args.after / run / METRICS).exists():
            line, bad = "DIFFERS: not trained after", True
        else:
            line, bad = compare(args.before / run, args.after / run)
        differs |= bad
        print(f"{run}: {line}")
    return 1 if differs else 0


if __name__ == "__main__":
    sys.exit(main())
