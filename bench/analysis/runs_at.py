"""The command line of the scripts that read runs at points T on a counter
(``delivered_episodes.py``, ``seed_values.py``): ``DIR [DIR ...] --at T1,T2,... [--counter C]``."""

from __future__ import annotations

import argparse
from pathlib import Path

from maopg.experiment.studies.runs import RunData, discover_runs


def runs_at(
    doc: str, parser: argparse.ArgumentParser | None = None
) -> tuple[list[RunData], list[int], str, argparse.Namespace]:
    """Every run directory under the command line's ``DIR`` folders, finished or not, the points
    T (positive, ascending), the counter (maopg's ``samples`` by default) and the parsed
    arguments (``parser``: a script's own, its options already added)."""
    parser = parser or argparse.ArgumentParser(description=doc.split("\n")[0])
    parser.add_argument("dirs", nargs="+", type=Path)
    parser.add_argument("--at", required=True, help="points T, comma-separated, ascending")
    parser.add_argument("--counter", default="samples")
    args = parser.parse_args()
    points = [int(t) for t in args.at.split(",")]
    if points != sorted(set(points)) or points[0] <= 0:
        parser.error(f"--at must be positive and ascending, got {args.at}")
    return discover_runs(args.dirs, unfinished=True), points, args.counter, args


def label(run: RunData) -> str:
    """A run's row label: its directory, relative to the working directory where it lies below
    it (runs of one method and seed from two pilots differ only there)."""
    try:
        return str(run.path.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(run.path)
