"""The published Box Pushing runs seed by seed: each seed's value at T from the ACAC authors'
logged evaluations (``docs/results/published_box_pushing.md`` holds what this prints).

Run: ``.venv/bin/python bench/analysis/published_seeds.py GIT_DIR`` with ``GIT_DIR`` a mirror of
``LGAI-Research/acac`` (it only reads, through ``git show`` at :data:`COMMIT`). A seed's value at
T is the mean of its last 5 logged ``Eval/Return`` values with ``Timesteps`` ≤ T (fewer where
fewer lie below T, marked ``(n=…)``); "big" = its value at 500K is ≥ 200. Last, it checks the
values the studies compare with (``maopg.experiment.studies.published.PUBLISHED_RUNS``, 3
decimals) against the logs.
"""

from __future__ import annotations

import argparse
import csv
import io
import statistics
import subprocess

from maopg.experiment.studies.published import PUBLISHED_RUNS

COMMIT = "26b94d99b459ebc61ce9c7fe0b09408dd3fe876b"
STEPS = (50_000, 100_000, 200_000, 300_000, 500_000)
ENVS = ("bp6", "bp8", "bp10")
METHODS = ("acac", "mac_iaicc", "mac_niacc", "mappo")


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
                big = "Y" if per_step[STEPS[-1]][-1] >= 200 else "N"
                print(f"| {method} | {seed} | {' | '.join(cells)} | {big} |")
            summary = " | ".join(
                f"{statistics.mean(v):.1f} ± {statistics.stdev(v):.1f}" for v in per_step.values()
            )
            print(f"| {method} | mean ± SD | {summary} | |")
    print(
        "\nPUBLISHED_RUNS (maopg.experiment.studies.published) against these logs: "
        + ("; ".join(differ) if differ else "every value matches to 3 decimals")
    )


if __name__ == "__main__":
    main()
