"""How often ``async`` from RGB on Tool Delivery collapses early, trained with
``env.appearance=off`` and with ``full``: the vision study's ``full`` seed 1 settled within
its first 10K samples on one deterministic joint option choice that never delivers (entropy
below 3e-5 from 6.3K samples on, every episode −150 to −153) and scored −0.29 in every look,
where no ``off`` seed did. Three seeds a look cannot say whether randomised looks make that
likelier; this probe trains more seeds of both looks at the study's settings to 10K samples,
where the collapse shows, each run persisted in ``results/vision/collapse/<look>/seed<k>``
(config, metrics, ``done.json``; weights stay local), so ``run`` resumes where a session
stopped and ``table`` regenerates the table from the logged runs.

    python bench/analysis/vision_collapse.py run [--jobs 2]
    python bench/analysis/vision_collapse.py table > results/vision/collapse.md

Seed 1 is among the probe's seeds: its 10K samples must log the study's run's first 10K
exactly, in either look (the same seed and settings; checked by ``table``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from pilot_runs import finished, train_command, train_runs

from maopg.experiment.run.directory import read_metrics
from maopg.experiment.studies.vision import SEEDS as STUDY_SEEDS
from maopg.experiment.studies.vision import VARIANTS

ROOT = Path("results/vision/collapse")
STUDY_RUNS = Path("results/vision/runs")
TASK = "tool_delivery"
LOOKS = ("off", "full")
PROBED = (1, 3, 4, 5, 6, 7, 8)
"""The seeds the probe trains: the study's seeds are 0-2, whose first 10K samples the table
reads from the study's runs; seed 1 is trained again to check the probe against them."""
SEEDS = tuple(sorted({*STUDY_SEEDS, *PROBED}))
BUDGET = 10_000
COLLAPSED = 0.01
"""A run collapsed when its policy's entropy, averaged over its last 5 iterations, is below
this: every agent's choice near-certain (above 0.999 for one option of six) at 10K samples,
where the runs that go on to learn still spread theirs (0.1 and more); a clipped policy
gradient then all but never samples the options that would pay again."""


def command(look: str, seed: int) -> list[str]:
    """The ``train`` command of a probe run: the vision study's variant ``look`` on Tool
    Delivery (its task settings and overrides), at the probe's budget."""
    study = next(v.study for v in VARIANTS if v.name == look)
    task = study.task(TASK)
    settings = {f"env.{k}": v for k, v in task.settings.items()}
    settings |= dict(study.overrides) | {
        "video": False,
        "plot": False,
        "progress": False,
        "eval_episodes": 0,
    }
    return train_command(TASK, "async", seed, BUDGET, ROOT / look / f"seed{seed}", settings)


def _rows(path: Path) -> list[dict[str, str]]:
    return read_metrics(path / "metrics.csv")


def _study_run(look: str, seed: int) -> Path:
    return STUDY_RUNS / look / TASK / "async" / f"seed{seed}"


def logged(look: str, seed: int) -> list[dict[str, str]] | None:
    """A seed's iterations up to the probe's budget: the study's run's first ones for the
    study's seeds, the probe's run for the others (``None``: not trained yet)."""
    if seed in STUDY_SEEDS:
        path = _study_run(look, seed)
        if not finished(path):
            return None
        rows = _rows(path)
        end = next(i for i, r in enumerate(rows) if int(r["samples"]) >= BUDGET)
        return rows[: end + 1]
    path = ROOT / look / f"seed{seed}"
    return _rows(path) if finished(path) else None


def table() -> str:
    """The probe's table from the logged runs."""
    lines = [
        f"`async` from RGB on Tool Delivery at the vision study's settings, {BUDGET // 1000}K "
        "samples; entropy: the policy's mean entropy over the last 5 iterations (collapsed: "
        f"below {COLLAPSED:g}); return: the mean training-episode return over the last 2K "
        "samples (the random team scores −57.7, an idle one −150).",
        "",
        "| look | seed | run | entropy | return | collapsed |",
        "|---|---|---|---|---|---|",
    ]
    counts = {}
    for look in LOOKS:
        done = 0
        collapsed = 0
        for seed in SEEDS:
            rows = logged(look, seed)
            source = "the study's" if seed in STUDY_SEEDS else "the probe's"
            if rows is None:
                lines.append(f"| {look} | {seed} | {source} | — | — | not run yet |")
                continue
            entropy = float(np.mean([float(r["entropy"]) for r in rows[-5:]]))
            last = int(rows[-1]["samples"]) - 2_000
            returns = [
                float(r["episode_return"])
                for r in rows
                if int(r["samples"]) > last and r["episode_return"] != "nan"
            ]
            is_collapsed = entropy < COLLAPSED
            done += 1
            collapsed += is_collapsed
            lines.append(
                f"| {look} | {seed} | {source} | {entropy:.2g} | {np.mean(returns):.1f} | "
                f"{'yes' if is_collapsed else 'no'} |"
            )
        counts[look] = (collapsed, done)
    lines += [""] + [f"- `{k}`: {c} of {n} seeds collapsed" for k, (c, n) in counts.items()]
    for look in LOOKS:
        probe, study = ROOT / look / "seed1", logged(look, 1)
        if finished(probe) and study is not None:
            keys = ("samples", "episode_return", "entropy", "policy_loss")
            mine = [[r[k] for k in keys] for r in _rows(probe)]
            theirs = [[r[k] for k in keys] for r in study]
            same = "identical to" if mine == theirs else "DIFFERENT from"
            lines.append(f"- `{look}` seed 1's {len(mine)} iterations: {same} the study's run's")
    lines += ["", f"Command (`full`, seed 1): `{' '.join(command('full', 1))}`"]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("run").add_argument("--jobs", type=int, default=1)
    sub.add_parser("table")
    args = parser.parse_args()
    if args.command == "run":
        runs = [(command(look, s), ROOT / look / f"seed{s}") for s in PROBED for look in LOOKS]
        train_runs(runs, args.jobs)
    else:
        print(table(), end="")


if __name__ == "__main__":
    main()
