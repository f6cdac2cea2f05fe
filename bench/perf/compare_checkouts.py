"""Old vs new checkout: simulation-core, Tool Delivery and training-loop throughput, side by side.

Run: ``.venv/bin/python bench/perf/compare_checkouts.py [--ref 0c4d129] [--rounds N] [--sections
sim,td,train,methods]``. Prints a Markdown block for BENCHMARKS.md (progress goes to stderr).

Why this exists: a redesign must not make the simulation core or the Tool Delivery environment
slower, but a figure from last week's BENCHMARKS.md and one measured today are not comparable on
a shared 2-core machine, whose load changes by the minute. So both versions are measured in one
run, *alternately*: for every round and every section, the old checkout's script and the new
tree's run back to back, each in a fresh subprocess, and the one that goes first swaps every
round (old, new, new, old, old, new, ...). A change of machine load then hits both sides alike
instead of biasing whichever side happened to run during it; the swap also cancels a steady
drift and any advantage of going first or second in a pair (trial runs in plain old/new
order suggested one of a few percent on ``mj_step``). The spread over the rounds shows how large
the noise is.

- *old*: ``git archive REF`` unpacked into a temporary folder (removed afterwards).
- *new*: a snapshot of the working tree (tracked and untracked, non-ignored files) copied into
  the same temporary folder at the start, so every round measures the same code even while the
  tree is being edited.

Each side runs its *own* ``bench/perf/sim_bench.py`` and ``bench/perf/td_bench.py`` (the
``train`` section:
the new tree's ``bench/perf/train_rate.py``, which drives only the ``python -m train`` command line
that every version has) with the same Python
(``sys.executable``), ``PYTHONPATH=<checkout>`` and the temporary folder as working directory,
so ``import maopg`` resolves to that checkout and not to the editable install of the repository
(the editable finder sits after ``PYTHONPATH`` on the import path, but this is checked rather
than assumed: every ``maopg`` module each run loaded must come from its own checkout, or the
comparison stops). The figures are parsed from the Markdown tables the scripts print.

Verdict per figure: *noise* when the old and new min–max ranges over the rounds overlap;
otherwise the difference is beyond the spread. Two samples of N rounds drawn from the same
distribution separate completely with probability 2 / C(2N, N), 0.2% per figure at the default
N = 6, so a separation is a real difference, not bad luck.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import statistics
import subprocess
import sys
import tarfile
import tempfile
import textwrap
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))  # this tree's sysinfo helper, whatever maopg is installed

from maopg.experiment.run.sysinfo import markdown  # noqa: E402

DEFAULT_REF = "0c4d129"
MARK = "@@compare_checkouts@@"

# Runs one benchmark script in a fresh interpreter and reports where maopg came from. argv:
# checkout root, script, script args. Prints the script's own output, then one MARK line.
RUNNER = textwrap.dedent(
    f"""
    import runpy, sys
    from pathlib import Path
    root, script, *args = sys.argv[1:]
    sys.argv = [script, *args]
    try:
        runpy.run_path(script, run_name="__main__")
    except SystemExit as stop:
        if stop.code not in (0, None):
            raise
    import maopg
    files = []
    for name, module in list(sys.modules.items()):
        if name == "maopg" or name.startswith("maopg."):
            files += [getattr(module, "__file__", None) or "", *getattr(module, "__path__", [])]
    home = Path(root).resolve()
    strays = sorted({{f for f in files if f and not Path(f).resolve().is_relative_to(home)}})
    print("{MARK}", maopg.__file__, *strays, sep="\\t")
    """
)


@dataclass(frozen=True)
class Column:
    """One figure column of a script's table; ``keys`` are the columns that name the row."""

    header: str
    keys: tuple[str, ...]
    higher_is_better: bool = False
    label: str = "{header}"  # how the figure is named, {header} being the column


@dataclass(frozen=True)
class Section:
    name: str  # for --sections
    title: str
    script: str
    args: tuple[str, ...]
    figures: tuple[Column, ...]
    # Columns that describe the workload: they must read the same on both sides, or the
    # figures compare different work (e.g. the environment's episodes changed length).
    workload: tuple[Column, ...]
    # Run the *new* tree's script against both checkouts: for a script that drives only what
    # every version has (the command line), and which the old checkout may not contain.
    script_from_new: bool = False


def sections(td_episodes: int) -> tuple[Section, ...]:
    scene = ("scene",)
    camera = ("scene", "setting")
    return (
        Section(
            "sim",
            "Simulation core",
            "sim_bench.py",
            (),
            (
                Column("mj_step (µs)", scene, False),
                Column("Scene.advance tick (ms)", scene, False),
                *(
                    Column(f"{s} px", camera, False, "camera frame {header} (ms)")
                    for s in (64, 84, 128)
                ),
            ),
            (Column("bodies/geoms/actuators", scene),),
        ),
        Section(
            "td",
            "Tool Delivery throughput",
            "td_bench.py",
            ("--episodes", str(td_episodes), "--repeats", "1"),
            (
                Column("env ticks/s", ("observations",), True),
                Column("bare ticks/s", ("observations",), True),
            ),
            (Column("ticks", ("observations",)), Column("frames", ("observations",))),
        ),
        Section(
            "train",
            "Training loop, `async` from RGB, command-line defaults",
            "train_rate.py",
            (),
            (Column("train samples/s", ("case",), True),),
            (Column("iterations", ("case",)),),
            script_from_new=True,
        ),
        Section(
            "methods",
            "Training loop on the 6x6 Box Pushing grid, each method at its defaults",
            "method_speed.py",
            (
                "--cases",
                "bp6",
                "--methods",
                "async,acac,mac-iaicc",
                "--samples",
                "20000",
                "--rounds",
                "1",
            ),
            (Column("samples/s", ("case", "method"), True),),
            (),
            script_from_new=True,
        ),
    )


def parse_tables(text: str) -> list[list[dict[str, str]]]:
    """Every Markdown table in ``text`` as a list of rows (header -> cell)."""
    tables: list[list[dict[str, str]]] = []
    block: list[list[str]] = []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            block.append([cell.strip() for cell in line.strip().strip("|").split("|")])
            continue
        if len(block) >= 2 and set("".join(block[1])) <= set("-: "):
            header = block[0]
            tables.append([dict(zip(header, row, strict=False)) for row in block[2:]])
        block = []
    return tables


def cells(text: str, column: Column) -> dict[str, str]:
    """Row name -> cell of ``column``, for every row of every table that has that column."""
    found = {}
    for table in parse_tables(text):
        for row in table:
            if column.header in row and all(k in row for k in column.keys):
                found[", ".join(row[k] for k in column.keys)] = row[column.header]
    return found


def number(cell: str) -> float:
    return float(cell.replace(",", "").rstrip("%"))


def decimals(cell: str) -> int:
    return len(cell.rstrip("%").partition(".")[2])


@dataclass
class Figure:
    """One figure of one table row: the cells each side printed, one per round."""

    column: Column
    cells: dict[str, list[str]] = field(default_factory=lambda: {"old": [], "new": []})

    def values(self, side: str) -> list[float]:
        return [number(c) for c in self.cells[side]]

    def show(self, side: str) -> str:
        """``median (min–max)`` with as many decimals as the script printed."""
        values = self.values(side)
        places = max(decimals(c) for c in self.cells[side])
        m, lo, hi = statistics.median(values), min(values), max(values)
        return f"{m:,.{places}f} ({lo:,.{places}f}–{hi:,.{places}f})"

    def ratio(self) -> float:
        """new / old of the medians, as the figure is printed (time or rate)."""
        return statistics.median(self.values("new")) / statistics.median(self.values("old"))

    def verdict(self) -> str:
        old, new = self.values("old"), self.values("new")
        old_m, new_m = statistics.median(old), statistics.median(new)
        # The change in time taken: for a rate, time goes as 1 / rate.
        slower = (old_m / new_m if self.column.higher_is_better else new_m / old_m) - 1
        if round(slower, 3) == 0:
            change = "same median"
        else:
            change = f"new {'slower' if slower > 0 else 'faster'} by {abs(slower):.1%}"
        if max(old) >= min(new) and max(new) >= min(old):
            return f"noise (ranges overlap; {change})"
        return f"**beyond noise: {change}**"


@dataclass
class Checkout:
    side: str  # "old" or "new"
    root: Path
    description: str
    maopg_file: str = ""


def make_old(ref: str, into: Path) -> Checkout:
    commit = git("rev-parse", "--verify", f"{ref}^{{commit}}")
    into.mkdir()
    archive = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", commit], capture_output=True, check=True
    ).stdout
    with tempfile.TemporaryFile() as tar_file:
        tar_file.write(archive)
        tar_file.seek(0)
        with tarfile.open(fileobj=tar_file) as tar:
            tar.extractall(into, filter="data")
    return Checkout("old", into, f"`{git('log', '-1', '--format=%h %s', commit)}`")


def make_new(into: Path) -> Checkout:
    listed = git("ls-files", "-z", "--cached", "--others", "--exclude-standard").split("\0")
    copied = 0
    for name in filter(None, listed):
        source = REPO / name
        if source.is_file():  # deleted-but-tracked files are listed too
            (into / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, into / name)
            copied += 1
    changes = len(git("status", "--porcelain").splitlines())
    head = git("log", "-1", "--format=%h")
    return Checkout(
        "new",
        into,
        f"snapshot of the working tree ({copied} files): HEAD `{head}` + {changes} uncommitted "
        f"change{'s' if changes != 1 else ''}",
    )


def checkouts(ref: str, work: Path) -> tuple[Checkout, Checkout, Path]:
    """The old (``ref``) and new (working tree) checkouts under ``work``, and an empty working
    directory inside neither, so that ``import maopg`` can only come from ``PYTHONPATH``."""
    old = make_old(ref, work / "old")
    new = make_new(work / "new")
    cwd = work / "cwd"
    cwd.mkdir()
    return old, new, cwd


def git(*args: str) -> str:
    return subprocess.run(
        ["git", "-C", str(REPO), *args], capture_output=True, text=True, check=True
    ).stdout.strip()


def run_section(
    checkout: Checkout, section: Section, others: list[Path], cwd: Path, new: Checkout
) -> str:
    """Run the checkout's own script for ``section`` (or the new tree's, if the section says
    so); return its stdout, checked for imports."""
    bench = (new if section.script_from_new else checkout).root / "bench"
    script = bench / "perf" / section.script  # bench/ was flat before its perf/analysis split
    if not script.exists():
        script = bench / section.script
    return run_script(checkout, script, section.args, others, cwd)


def run_script(
    checkout: Checkout, script: Path, args: tuple[str, ...], others: list[Path], cwd: Path
) -> str:
    """Run ``script args`` with ``maopg`` imported from ``checkout`` (checked: no module from
    ``others``); return its stdout. ``bench/perf/startup.py`` times these runs."""
    env = {**os.environ, "PYTHONPATH": str(checkout.root)}
    command = [sys.executable, "-c", RUNNER, str(checkout.root), str(script), *args]
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=3600)
    if done.returncode != 0:
        raise RuntimeError(
            f"{checkout.side} {script.name} failed (exit {done.returncode}):\n{done.stderr[-3000:]}"
        )
    marks = [line for line in done.stdout.splitlines() if line.startswith(MARK)]
    _, maopg_file, *strays = marks[-1].split("\t")
    if strays or any(Path(maopg_file).is_relative_to(other) for other in others):
        raise RuntimeError(
            f"{checkout.side} {script.name} imported maopg from outside {checkout.root}: "
            f"maopg at {maopg_file}, strays {strays}"
        )
    if not checkout.maopg_file:
        checkout.maopg_file = maopg_file
        print(f"[{checkout.side}] maopg.__file__ = {maopg_file}", file=sys.stderr)
    return done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ref", default=DEFAULT_REF, help="the old commit (default: %(default)s)")
    parser.add_argument(
        "--rounds",
        type=int,
        default=6,
        help="old/new pairs per section (even: each side goes first equally often)",
    )
    parser.add_argument(
        "--td-episodes", type=int, default=20, help="td_bench episodes per run (one repeat)"
    )
    parser.add_argument(
        "--sections",
        default="sim,td,train",
        help="comma-separated, of sim (simulation core), td (Tool Delivery environment), "
        "train (training loop, bench/perf/train_rate.py), methods (async, ACAC and "
        "Mac-IAICC on the 6x6 grid, bench/perf/method_speed.py); default: %(default)s",
    )
    args = parser.parse_args()
    if args.rounds < 2:
        parser.error("--rounds must be at least 2: the verdicts compare the rounds' spread")
    started = time.perf_counter()
    conditions = markdown()  # before anything runs: its load average is the one at start
    wanted = args.sections.split(",")
    runs = tuple(s for s in sections(args.td_episodes) if s.name in wanted)
    if len(runs) != len(wanted):
        parser.error(f"--sections: choose from {[s.name for s in sections(0)]}")
    # (section, row name, column header) -> figure, and (section, row, header) -> cells seen
    figures: dict[tuple[str, str, str], Figure] = {}
    workload: dict[tuple[str, str, str], dict[str, set[str]]] = {}
    loads: list[float] = []
    with tempfile.TemporaryDirectory(prefix="maopg-compare-") as tmp:
        old, new, cwd = checkouts(args.ref, Path(tmp))
        for round_ in range(args.rounds):
            for section in runs:
                pair = ((old, new), (new, old))
                for checkout, other in pair if round_ % 2 == 0 else pair[::-1]:
                    print(
                        f"round {round_ + 1}/{args.rounds}: {checkout.side} {section.script}",
                        file=sys.stderr,
                    )
                    loads.append(os.getloadavg()[0])
                    # The repository itself is excluded too: that is the editable install.
                    out = run_section(checkout, section, [other.root, REPO], cwd, new)
                    for column in section.figures:
                        for row, cell in cells(out, column).items():
                            key = (section.title, row, column.header)
                            figure = figures.setdefault(key, Figure(column))
                            figure.cells[checkout.side].append(cell)
                    for column in section.workload:
                        for row, cell in cells(out, column).items():
                            seen = workload.setdefault((section.title, row, column.header), {})
                            seen.setdefault(checkout.side, set()).add(cell)
    elapsed = time.perf_counter() - started

    n = args.rounds
    chance = 2 / math.comb(2 * n, n)
    print("### Old vs new checkout, side by side (`bench/perf/compare_checkouts.py`)\n")
    print(conditions)
    print(f"- load average (1 min) before each run: {min(loads):.2f}–{max(loads):.2f}")
    print(f"- load average (1 min) at end: {os.getloadavg()[0]:.2f}")
    print(f"- old: {old.description}; maopg imported from `{old.maopg_file}`")
    print(f"- new: {new.description}; maopg imported from `{new.maopg_file}`")
    print(
        f"- {n} rounds; in each, every section's script ran from both checkouts back to back, "
        f"each in a fresh subprocess, old first in odd rounds and new first in even ones "
        f"(`td_bench.py` with "
        f"`--episodes {args.td_episodes} --repeats 1`); total wall time {elapsed / 60:.1f} min"
    )
    print(
        f"- median (min–max) over the rounds; *noise* = the old and new ranges overlap (two "
        f"equal distributions separate completely by chance 1 time in {round(1 / chance):,} per "
        "figure); slower/faster = change in time taken\n"
    )
    print("| section | row | figure | old | new | new/old | verdict |")
    print("|---|---|---|---|---|---|---|")
    for section in runs:
        rows = list(dict.fromkeys(row for (title, row, _) in figures if title == section.title))
        for row in rows:
            for column in section.figures:
                figure = figures.get((section.title, row, column.header))
                if figure is None:
                    continue
                label = column.label.format(header=column.header)
                head = f"| {section.title} | {row} | {label} |"
                missing = [side for side, got in figure.cells.items() if len(got) != n]
                if missing:
                    print(f"{head} | | | not measured in every {'/'.join(missing)} run |")
                    continue
                print(
                    f"{head} {figure.show('old')} | {figure.show('new')} | {figure.ratio():.3f} "
                    f"| {figure.verdict()} |"
                )
    print("\nSame workload on both sides (the figures compare like with like only if so):\n")
    for (title, row, header), seen in workload.items():
        everything = seen.get("old", set()) | seen.get("new", set())
        if len(everything) == 1 and len(seen) == 2:
            print(f"- {title}, {row}, {header}: {everything.pop()} in every run")
        else:
            found = "; ".join(f"{side} {', '.join(sorted(v))}" for side, v in sorted(seen.items()))
            print(f"- {title}, {row}, {header}: **differs** ({found})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
