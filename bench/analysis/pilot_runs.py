"""Training the runs of a pilot script (``exploration_pilots.py``, ``few_episode_pilots.py``,
``vision_collapse.py``): each run a ``python -m train`` command in a run directory of its own,
so a script stopped with its session resumes where it stopped and skips what is done, and a
pilot table is read from the logged runs alone."""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any


def setting_text(value: Any) -> str:
    """A setting's value as the ``train`` command line takes it (``true``, not ``True``)."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def train_command(
    task: str, method: str, seed: int, samples: int, run_dir: Path, settings: Mapping[str, Any]
) -> list[str]:
    """``python -m train`` of one run, as a pilot table prints it (:func:`train_run` runs it
    with this interpreter)."""
    return [
        *("python", "-m", "train", "--task", task, "--method", method),
        *("--seed", str(seed), "--total-samples", str(samples), "--run-dir", str(run_dir)),
        *(f"{key}={setting_text(value)}" for key, value in settings.items()),
    ]


def finished(path: Path) -> bool:
    """Whether the run in ``path`` trained to its budget."""
    return (path / "done.json").exists()


def train_run(command: list[str], path: Path) -> str:
    """Run the ``train`` ``command`` whose run directory is ``path``: nothing if it is done,
    ``--resume`` where a checkpoint is, ``--overwrite`` over a run killed before its first
    one; its output goes to ``seed<k>.log`` beside the run. One line saying how it ended."""
    if finished(path):
        return f"{path}: done"
    if command[0] == "python":  # as printed: run it with this interpreter
        command = [sys.executable, *command[1:]]
    if (path / "checkpoint.pt").exists():
        command = [*command, "--resume"]
    elif path.exists():
        command = [*command, "--overwrite"]
    log = path.parent / f"{path.name}.log"
    path.parent.mkdir(parents=True, exist_ok=True)
    with log.open("w") as out:
        code = subprocess.call(command, stdout=out, stderr=subprocess.STDOUT)
    return f"{path}: {'finished' if code == 0 else f'FAILED ({code}), see {log}'}"


def train_runs(runs: Iterable[tuple[list[str], Path]], jobs: int = 1) -> None:
    """:func:`train_run` each ``(command, run directory)``, ``jobs`` at a time, printing a line
    as each ends."""
    with ThreadPoolExecutor(jobs) as pool:
        for line in pool.map(lambda run: train_run(*run), runs):
            print(line, flush=True)


def commands_text(commands: Mapping[str, list[str]]) -> list[str]:
    """A pilot table's closing lines: each pilot's seed-0 ``train`` command."""
    lines = ["", "Commands (seed 0; the others differ in `--seed` and `--run-dir`):"]
    return lines + [f"- `{name}`: `{' '.join(command)}`" for name, command in commands.items()]


def pilot_main(
    doc: str, names: Iterable[str], run: Callable[[list[str]], None], table: Callable[[], str]
) -> None:
    """The command line of a pilot script: ``run [PILOT ...]`` trains the named pilots (all by
    default), ``table`` prints the pilot table."""
    names = list(names)
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("run").add_argument("pilots", nargs="*", help=", ".join(names))
    sub.add_parser("table")
    args = parser.parse_args()
    if args.command == "run":
        unknown = [name for name in args.pilots if name not in names]
        if unknown:
            parser.error(f"unknown pilot {unknown[0]!r}; pilots: {', '.join(names)}")
        run(args.pilots)
    else:
        print(table(), end="")
