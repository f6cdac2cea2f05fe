"""The published Box Pushing runs seed by seed: each seed's value at T from the ACAC authors'
logged evaluations (``docs/results/published_box_pushing.md`` holds what this prints).

Run: ``.venv/bin/python bench/analysis/published_seeds.py GIT_DIR`` with ``GIT_DIR`` a mirror of
``LGAI-Research/acac`` (it only reads, through ``git show`` at :data:`COMMIT`). A seed's value at
T is the mean of its last 5 logged ``Eval/Return`` values with ``Timesteps`` ≤ T (fewer where
fewer lie below T, marked ``(n=…)``); "big" = its value at 500K is ≥ 200. Last, it checks the
values the studies compare with (``maopg.experiment.studies.published.PUBLISHED_RUNS``, 3
decimals) against the logs.

Then the logs' row spacing: how many ``Timesteps`` each row adds to the one before (the first:
to 0) in the first 10 rows (ε near 1, before anything is learned) and in the rows at the big
box (return ≥ 200), with those rows' mean return, and each seed's lowest row. Rows come at a
fixed cadence of episodes, so where the first rows of two methods are alike and their big-box
rows are not, the episodes trained on between two rows took that many more steps: what a
converged curve's level alone does not say.
"""

from __future__ import annotations

import argparse
import csv
import functools
import io
import statistics
import subprocess

from maopg.experiment.studies.published import PUBLISHED_RUNS

COMMIT = "26b94d99b459ebc61ce9c7fe0b09408dd3fe876b"
STEPS = (50_000, 100_000, 200_000, 300_000, 500_000)
ENVS = ("bp6", "bp8", "bp10")
METHODS = ("acac", "mac_iaicc", "mac_niacc", "mappo")
ACTOR_CRITICS = METHODS[:3]
"""The macro-action actor-critics: the logs whose rows come at one cadence of episodes."""


@functools.cache
def load(git_dir: str, path: str) -> list[tuple[float, float]]:
    """``(Timesteps, Eval/Return)`` rows of one logged run."""
    text = subprocess.run(
        ["git", f"--git-dir={git_dir}", "show", f"{COMMIT}:{path}"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return [
        (float(r["Timesteps"]), float(r["Eval/Return"])) for r in csv.DictReader(io.StringIO(text))
    ]


def value_at(rows: list[tuple[float, float]], steps: int) -> tuple[float, int]:
    """The mean of the last 5 returns logged at or before ``steps``, and how many there were."""
    last = [ret for t, ret in rows if t <= steps][-5:]
    return sum(last) / len(last), len(last)


BIG = 200.0
"""A logged return at or above this delivered the big box."""
FIRST_ROWS = 10


def median_gap(rows: list[tuple[float, float]], keep: list[bool]) -> float | None:
    """The median of the ``Timesteps`` each kept row adds to the row before it (the first row:
    to 0)."""
    starts = [0.0, *(t for t, _ in rows[:-1])]
    gaps = [t - prev for (t, _), prev, k in zip(rows, starts, keep, strict=True) if k]
    return statistics.median(gaps) if gaps else None


def spacing(git_dir: str) -> None:
    """Per size and method: each seed's median row gap in its first rows and at the big box,
    the mean return of its big-box rows and its lowest row."""
    print("\n### Row spacing (Timesteps between consecutive rows) and the lowest row")
    header = [
        "env",
        "method",
        "first 10 rows: median gap, per seed",
        "big-box rows: median gap, per seed",
        "big-box rows: mean return, per seed",
        "lowest row, per seed",
    ]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for env in ENVS:
        for method in ACTOR_CRITICS:
            first, big, level, lowest = [], [], [], []
            for seed in range(5):
                rows = load(git_dir, f"icml25_result/log/{env}/{method}/{seed}.csv")
                gap = median_gap(rows, [i < FIRST_ROWS for i in range(len(rows))])
                first.append(f"{gap:.0f}")
                gap = median_gap(rows, [ret >= BIG for _, ret in rows])
                big.append("—" if gap is None else f"{gap:.0f}")
                kept = [ret for _, ret in rows if ret >= BIG]
                level.append(f"{statistics.mean(kept):.1f}" if kept else "—")
                lowest.append(f"{min(ret for _, ret in rows):.1f}" if rows else "—")
            cells = [env, method, *(", ".join(c) for c in (first, big, level, lowest))]
            print("| " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("git_dir", help="a mirror of LGAI-Research/acac")
    args = parser.parse_args()
    differ = []
    for env in ENVS:
        print(
            f"\n### {env}\n| method | seed | {' | '.join(f'{s // 1000}K' for s in STEPS)} | big |"
        )
        print("|---|---|" + "---|" * len(STEPS) + "---|")
        for method in METHODS:
            per_step: dict[int, list[float]] = {s: [] for s in STEPS}
            for seed in range(5):
                rows = load(args.git_dir, f"icml25_result/log/{env}/{method}/{seed}.csv")
                cells = []
                for s in STEPS:
                    value, count = value_at(rows, s)
                    per_step[s].append(value)
                    stored = PUBLISHED_RUNS[env][method][seed][STEPS.index(s)]
                    if abs(stored - value) > 0.0005 + 1e-9:
                        differ.append(f"{env} {method} seed {seed} at {s}: {stored} ≠ {value}")
                    cells.append(f"{value:.1f}" + ("" if count == 5 else f" (n={count})"))
                big = "Y" if per_step[STEPS[-1]][-1] >= BIG else "N"
                print(f"| {method} | {seed} | {' | '.join(cells)} | {big} |")
            summary = " | ".join(
                f"{statistics.mean(v):.1f} ± {statistics.stdev(v):.1f}" for v in per_step.values()
            )
            print(f"| {method} | mean ± SD | {summary} | |")
    spacing(args.git_dir)
    print(
        "\nPUBLISHED_RUNS (maopg.experiment.studies.published) against these logs: "
        + ("; ".join(differ) if differ else "every value matches to 3 decimals")
    )


if __name__ == "__main__":
    main()
