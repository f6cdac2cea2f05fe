"""Pilots of a literature method on the 6x6 Box Pushing grid against its authors' logged curves
(``mac_iaicc_pilots.py``, ``acac_pilots.py``): each pilot changes one setting of the
``box-pushing-6`` study's runs of the method, trains a few seeds to the study's budget, and is
read as the study's validation reads it, on the published counter.

Each run is persisted in ``results/box-pushing-6/pilots/<method>/<pilot>/seed<k>`` (config,
metrics, ``done.json``; weights stay local), so ``run`` resumes where a session stopped and
``table`` regenerates the pilot table from the logged runs; the study's own seeds are the
baseline row.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pilot_runs import commands_text, finished, pilot_main, train_command, train_runs

from maopg.experiment.studies import get_study
from maopg.experiment.studies.published import (
    BIG_BOX,
    EVAL_RETURN,
    PUBLISHED_COUNTER,
    PUBLISHED_RUNS,
    PUBLISHED_SAMPLES,
    VALIDATED,
    VALIDATION_SAMPLES,
    final_value,
    outcome,
    value_at,
)
from maopg.experiment.studies.runs import RunData, discover_runs, load_run
from maopg.experiment.studies.stats import fisher_exact

STUDY = "box-pushing-6"
PILOT_ROOT = Path("results/box-pushing-6/pilots")
STUDY_RUNS = Path("results/box-pushing-6/runs/box_pushing_grid")


@dataclass(frozen=True)
class Pilot:
    about: str
    settings: dict[str, Any]


@dataclass(frozen=True)
class PilotSet:
    """One method's pilots: ``heading`` opens the table, ``seeds`` train for each pilot."""

    method: str
    seeds: tuple[int, ...]
    heading: str
    pilots: dict[str, Pilot]
    also: Path | None = None
    """Another study's runs of the method at the study's settings, other seeds: counted with
    the study's own in the table's last line."""

    def study_settings(self) -> dict[str, Any]:
        """The study's settings of a run of the method, with its budget (``total_samples``)."""
        (task,) = get_study(STUDY).tasks
        settings = {**get_study(STUDY).overrides, **task.train_settings(self.method)}
        return {**settings, "video": False, "plot": False, "progress": False, "eval_episodes": 0}

    def run_dir(self, name: str, seed: int) -> Path:
        return PILOT_ROOT / self.method / name / f"seed{seed}"

    def command(self, name: str, seed: int) -> list[str]:
        """The ``train`` command line of the pilot ``name``'s seed."""
        settings = {**self.study_settings(), **self.pilots[name].settings}
        budget = settings.pop("total_samples")
        run_dir = self.run_dir(name, seed)
        return train_command("box_pushing_grid", self.method, seed, budget, run_dir, settings)

    def run(self, names: list[str]) -> None:
        """Train every seed of the named pilots (all by default) that has not finished."""
        train_runs(
            (self.command(name, seed), self.run_dir(name, seed))
            for name in names or self.pilots
            for seed in self.seeds
        )

    def table(self) -> str:
        """The pilot table from the logged runs, the study's own seeds first."""
        theirs = PUBLISHED_RUNS["bp6"][VALIDATED[self.method]]
        big = f"big box at 500K, against the authors' {big_box_count(theirs)} of {len(theirs)}"
        seeds = " | ".join(f"seed {seed}" for seed in self.seeds)
        lines = [
            self.heading,
            "",
            f"| pilot | setting | {seeds} | {big} |",
            "|---|---|" + "---|" * (len(self.seeds) + 1),
        ]
        study = [load_run(STUDY_RUNS / self.method / f"seed{seed}") for seed in self.seeds]
        done = [r for r in study if r.finished]
        cells = [seed_cell(r) if r.finished else "—" for r in study]
        count = count_cell(done, theirs)
        lines.append(f"| `{STUDY}` | the study's settings | {' | '.join(cells)} | {count} |")
        for name, pilot in self.pilots.items():
            paths = [self.run_dir(name, seed) for seed in self.seeds]
            loaded = [load_run(p) if finished(p) else None for p in paths]
            runs = [r for r in loaded if r is not None]
            cells = [seed_cell(r) if r is not None else "—" for r in loaded]
            count = count_cell(runs, theirs)
            lines.append(f"| `{name}` | {pilot.about} | {' | '.join(cells)} | {count} |")
        if self.also is not None:
            more = discover_runs([self.also])
            lines += [
                "",
                f"The study's settings with the {len(more)} seeds of `{self.also}` too: "
                f"{count_cell([*done, *more], theirs)}.",
            ]
        lines += commands_text({name: self.command(name, 0) for name in self.pilots})
        return "\n".join(lines) + "\n"

    def main(self, doc: str) -> None:
        pilot_main(doc, self.pilots, self.run, self.table)


def at_text() -> str:
    """The validation's points, as a table's heading names them: ``100K / 200K / 500K``."""
    return " / ".join(f"{t // 1000}K" for t in VALIDATION_SAMPLES)


def seed_cell(run: RunData) -> str:
    """A seed's values at the validation's T on the published counter, its lowest evaluation
    and what its final value says it learnt."""
    values = " / ".join(
        f"{value_at(run, t, counter=PUBLISHED_COUNTER):.1f}" for t in VALIDATION_SAMPLES
    )
    lowest = float(np.nanmin(run.column(EVAL_RETURN)))
    return f"{values}; lowest {lowest:.1f}; {outcome(final_value(run))}"


def big_box_count(seeds: tuple[tuple[float, ...], ...]) -> int:
    """How many published seeds deliver the big box at the validation's last T."""
    last = PUBLISHED_SAMPLES.index(VALIDATION_SAMPLES[-1])
    return sum(values[last] >= BIG_BOX for values in seeds)


def count_cell(runs: list[RunData], theirs: tuple[tuple[float, ...], ...]) -> str:
    """``k of n`` of the runs at the big box at the validation's last T on the published counter,
    and Fisher's exact p against the published seeds' count; ``—`` for no run."""
    if not runs:
        return "—"
    values = [value_at(r, VALIDATION_SAMPLES[-1], counter=PUBLISHED_COUNTER) for r in runs]
    ours = sum(v >= BIG_BOX for v in values)
    p = fisher_exact(ours, len(runs), big_box_count(theirs), len(theirs))
    return f"{ours} of {len(runs)} (p = {p:.2f})"
