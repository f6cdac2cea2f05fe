"""The Box Pushing studies (issue #43): their definitions, and the tables that set their
evaluations during training beside the published curves (maopg.experiment.studies.published)."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from maopg.experiment.studies import Study, StudyTask, frozen, get_study, study_names
from maopg.experiment.studies.builtin import BOX_PUSHING_THRESHOLD, LITERATURE_EVALUATION
from maopg.experiment.studies.published import (
    BIG_BOX,
    PUBLISHED,
    PUBLISHED_COUNTER,
    PUBLISHED_METHODS,
    PUBLISHED_RUNS,
    PUBLISHED_SAMPLES,
    PUBLISHED_SEEDS,
    final_value,
    first_at_threshold,
    first_table,
    lowest_evaluations,
    outcome,
    outcome_table,
    over_seeds,
    validation_table,
    value_at,
    value_table,
)
from maopg.experiment.studies.results import reproduce
from maopg.experiment.studies.runs import RunData, discover_runs

DATA = Path(__file__).parents[1] / "data"
NAN = math.nan


def _run(seed: int, evaluations: list[float], success: list[float] | None = None) -> RunData:
    """A run of 1,000 samples an iteration that evaluated every second one (at 2K, 4K, ...),
    with a budget of 12K (the seeds of one group share their settings)."""
    rows = 2 * len(evaluations)
    returns = np.full(rows, NAN)
    returns[1::2] = evaluations
    rates = np.full(rows, NAN)
    rates[1::2] = success if success is not None else np.zeros(len(evaluations))
    return RunData(
        path=Path(f"/runs/seed{seed}"),
        task="box_pushing_grid",
        method="async",
        seed=seed,
        samples=np.arange(1, rows + 1) * 1000.0,
        metrics={"eval_return": returns, "eval_success": rates},
        finished=True,
        config={"total_samples": 12_000},
    )


# Evaluations at 2K, 4K, ..., 12K; the second run trains on to 14K.
FIRST = _run(0, [10, 20, 30, 40, 50, 60])
SECOND = _run(1, [0, 0, 0, 0, 300, 300, 300], [0, 0, 0, 0, 1, 1, 0.5])


def test_the_published_seeds_give_the_reference_table():
    """Every published seed's value, averaged over seeds, is the reference's §9 table (copied
    into tests/data) to its rounding: mean and sample SD to 0.1, give or take the seeds' own
    rounding to 3 decimals."""
    with (DATA / "box_pushing_published.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    table = {(r["env"], r["method"], int(r["samples"])): r for r in rows}
    derived = {
        (env, method, t): (mean, sd)
        for env, methods in PUBLISHED.items()
        for method, values in methods.items()
        for t, (mean, sd) in zip(PUBLISHED_SAMPLES, values, strict=True)
    }
    assert set(derived) == set(table)
    for key, (mean, sd) in derived.items():
        assert abs(mean - float(table[key]["mean"])) <= 0.051, key
        assert abs(sd - float(table[key]["sd"])) <= 0.051, key
    assert {m for _, m, _ in table} == set(PUBLISHED_METHODS)
    assert all(
        len(seeds) == PUBLISHED_SEEDS for m in PUBLISHED_RUNS.values() for seeds in m.values()
    )


def test_a_value_at_t_is_the_mean_of_the_last_five_evaluations_at_or_before_it():
    assert value_at(FIRST, 9_000) == 25.0  # 10, 20, 30, 40: fewer than five so far
    assert value_at(FIRST, 12_000) == 40.0  # 20 ... 60
    assert value_at(SECOND, 14_000) == 180.0  # 0, 0, 300, 300, 300
    assert math.isnan(value_at(FIRST, 1_500))  # no evaluation yet
    assert math.isnan(value_at(FIRST, 13_000))  # not trained that far
    assert math.isnan(value_at(FIRST, 12_000, "eval_length"))  # not logged
    assert value_at(SECOND, 14_000, "eval_success") == 0.5
    summary = over_seeds([40.0, 120.0, NAN])  # sample SD, as published: ddof 1
    assert (summary.mean, summary.std, summary.count) == (80.0, pytest.approx(56.5685), 2)


def test_the_value_table_sets_each_method_beside_the_published_rows():
    table = value_table([FIRST, SECOND], "bp8", (9_000, 12_000, 14_000, 50_000)).splitlines()
    assert table[0] == "| task | method | seeds | 9K | 12K | 14K | 50K |"
    # 9K: 25 and 0; 12K: 40 and 120; 14K: the second seed alone, marked (1).
    assert (
        table[2] == "| box_pushing_grid | async | 2 | 12.5 ± 17.7 | 80.0 ± 56.6 | 180.0 (1) | — |"
    )
    assert table[3] == "| bp8 (published) | ACAC | 5 | — | — | — | 28.8 ± 7.7 |"
    assert len(table) == 2 + 1 + len(PUBLISHED["bp8"])


def _counted(run: RunData, method: str, published_steps: np.ndarray) -> RunData:
    """``run`` as a run of ``method`` that also logs the published counter."""
    metrics = {**run.metrics, PUBLISHED_COUNTER: published_steps}
    return RunData(run.path, run.task, method, run.seed, run.samples, metrics, True, run.config)


def test_first_t_is_where_the_mean_of_the_seeds_values_reaches_the_threshold():
    """The published "first ≥ thr" on a 1,000-step grid, over the T both seeds reached (12K).
    The mean of the values: 45 at 10K (30 and 60), 80 at 12K (40 and 120)."""
    group = [FIRST, SECOND]
    assert first_at_threshold(group, 40.0) == 10_000
    assert first_at_threshold(group, 50.0) == 12_000
    assert math.isnan(first_at_threshold(group, 100.0))  # SECOND's 14K is past FIRST's end
    assert math.isnan(first_at_threshold(group, 1.0, counter=PUBLISHED_COUNTER))  # not logged
    table = first_table(group, "bp10").splitlines()
    assert table[0] == "| task | method | seeds | first T with the mean over seeds ≥ 200 |"
    assert table[2] == "| box_pushing_grid | async | 2 | not reached |"
    assert table[3] == "| bp10 (published) | ACAC | 5 | 135K |"
    assert table[4] == "| bp10 (published) | Mac-IAICC | 5 | not reached |"


def test_a_value_at_t_can_be_read_on_the_published_counter():
    # Every iteration of 1,000 samples counts 250 published steps: T = 2,000 is iteration 8.
    run = _counted(FIRST, "acac", np.arange(1, 13) * 250.0)
    assert value_at(run, 2_000, counter=PUBLISHED_COUNTER) == 25.0  # 10, 20, 30, 40 by then
    assert value_at(run, 3_000, counter=PUBLISHED_COUNTER) == 40.0
    assert math.isnan(value_at(run, 3_001, counter=PUBLISHED_COUNTER))  # not counted so far
    assert math.isnan(value_at(FIRST, 2_000, counter=PUBLISHED_COUNTER))  # not logged
    table = value_table([run], "bp6", (2_000,)).splitlines()
    assert table[2:4] == [
        "| box_pushing_grid | acac | 1 | 10.0 |",
        "| box_pushing_grid | acac, published counter | 1 | 25.0 |",
    ]


def test_a_validated_method_is_set_against_the_published_seeds():
    """Five seeds that count 500K published steps, each evaluating about 299.4 at the end: their
    mean lies in the bootstrap interval of the published bp6 ACAC seeds' mean at 500K, and 5 of
    5 big boxes match 5 of 5 (p = 1)."""
    steps = np.linspace(50_000, 500_000, 12)
    seeds = [
        _counted(_run(s, [30.0, 299.4, 299.4, 299.4, 299.3, 299.3]), "acac", steps)
        for s in range(5)
    ]
    rows = validation_table(seeds, "bp6").splitlines()
    assert rows[0] == (
        "| method | T (published counter) | maopg | published bp6 "
        "| published: bootstrap 95 % of the mean | matches |"
    )
    # At 500K each seed's last five: 299.4 three times, 299.3 twice: 299.36. The published
    # seeds: 299.4 twice, 299.3 three times; all five resampled at 299.3 in 0.6^5 = 8 %.
    assert rows[4].startswith("| acac | 500K | 299.36 (5 of 5) | 299.34 | [299.30, 299.38] |")
    assert rows[4].endswith("| yes |")
    assert rows[5] == "| acac | big box at 500K | 5 of 5 | 5 of 5 | Fisher exact p = 1.00 | yes |"
    assert rows[6] == (
        "| acac | big-box seeds at 500K | 299.36 (5) | 299.34 (5) | [299.30, 299.38] | yes |"
    )
    # The same runs as async are not a validated method; a small-box ACAC fails both checks,
    # and has no big-box seed to set against the published ones.
    assert validation_table([FIRST], "bp6") == ""
    small = [_counted(_run(s, [20.0] * 6), "acac", steps) for s in range(5)]
    rows = validation_table(small, "bp6").splitlines()
    assert rows[4].endswith("| no |")
    assert rows[5] == "| acac | big box at 500K | 0 of 5 | 5 of 5 | Fisher exact p = 0.01 | no |"
    assert rows[6] == "| acac | big-box seeds at 500K | — | — | — | — |"


def test_seeds_that_all_deliver_stand_above_a_mean_that_mixes_outcomes():
    """The published bp10 ACAC: four seeds at 298.8 or 298.9, one at 39.2. Five seeds at 298.9
    lie above the bootstrap interval of that mean, which no resample of five reaches, though
    the counts (5 of 5, 4 of 5) agree and each seed equals the best published one: the
    big-box seeds' row says so."""
    steps = np.linspace(50_000, 500_000, 12)
    seeds = [_counted(_run(s, [30.0] + [298.9] * 5), "acac", steps) for s in range(5)]
    rows = validation_table(seeds, "bp10").splitlines()
    assert rows[4].startswith("| acac | 500K | 298.90 (5 of 5) | 246.92 |")
    assert rows[4].endswith("| no |")
    assert rows[5] == "| acac | big box at 500K | 5 of 5 | 4 of 5 | Fisher exact p = 1.00 | yes |"
    assert rows[6].startswith(
        "| acac | big-box seeds at 500K | 298.90 (5) | 298.85 (4) | [298.80, "
    )
    assert rows[6].endswith("| yes |")


def test_each_seed_is_classed_by_what_its_final_value_says_it_delivers():
    assert [outcome(v) for v in (299.2, 200.0, 199.9, 40.1)] == [
        "big box",
        "big box",
        "big box at times",
        "big box at times",
    ]
    assert [outcome(v) for v in (40.0, 19.6, 15.0, 14.9, -10.0)] == [
        "small boxes only",
        "small boxes only",
        "small boxes only",
        "nothing",
        "nothing",
    ]
    assert outcome(NAN) == "not evaluated"
    assert BOX_PUSHING_THRESHOLD == BIG_BOX
    # Final: the value at the run's budget, 12K (0, 0, 0, 300, 300 for the second seed).
    assert (final_value(FIRST), final_value(SECOND)) == (40.0, 120.0)
    row = outcome_table([FIRST, SECOND]).splitlines()[2]
    assert row == (
        "| box_pushing_grid | async | 2 | 0 | 1 | 1 | 0 | seed0 40.0 (0%), seed1 120.0 (40%) "
        "| seed0 10.0, seed1 0.0 |"
    )
    # A seed that has logged no evaluation yet has no lowest one.
    unevaluated = _run(2, [NAN])
    assert lowest_evaluations([FIRST, unevaluated]) == "seed0 10.0, seed2 —"


BOX_PUSHING_STUDIES = [n for n in study_names() if n.startswith("box-pushing")]


@pytest.mark.parametrize("name", BOX_PUSHING_STUDIES)
def test_each_box_pushing_study_evaluates_as_the_literature_and_names_its_curves(name):
    study = get_study(name)
    (task,) = study.tasks
    assert study.published in PUBLISHED
    assert study.published == f"bp{task.settings['size']}"
    for method in study.methods:
        settings = {**study.overrides, **task.train_settings(method)}
        assert {k: settings[k] for k in LITERATURE_EVALUATION} == dict(LITERATURE_EVALUATION)


def test_the_box_pushing_studies_are_registered():
    grid = {"box-pushing-6", "box-pushing-8", "box-pushing-10"}
    mujoco = {"box-pushing-mujoco", "box-pushing-mujoco-rgb"}
    assert set(BOX_PUSHING_STUDIES) == grid | mujoco


def test_a_study_without_runs_writes_the_published_rows_alone(tmp_path):
    reproduce(tmp_path / "runs", tmp_path, study="box-pushing-10", train=False, eval_episodes=0)
    text = (tmp_path / "tables.md").read_text()
    assert "| bp10 (published) | ACAC | 5 | 25.8 ± 5.4 |" in text
    assert "no runs yet" in text


def test_a_tiny_study_writes_its_tables_and_figure_from_the_logged_evaluations(tmp_path):
    """Two seeds on the 4x4 grid, evaluating every 500 samples: the study's tables are read off
    its runs' ``metrics.csv`` by the published rule."""
    task = StudyTask("box_pushing_grid", (0, 1), frozen({"size": 4}))
    settings = {"total_samples": 3_000, "batch_ticks": 500, "plot": False}
    evaluation = {"eval_every": 500, "eval_during_episodes": 2}
    study = Study("tiny", "-", (task,), ("async",), frozen(settings | evaluation), published="bp6")
    results = tmp_path / "results"
    outcomes, written = reproduce(
        tmp_path / "runs",
        results,
        study=study,
        in_process=True,
        eval_episodes=0,
        log=lambda _: None,
    )
    assert set(outcomes.values()) == {"done"}
    assert {p.name for p in written} >= {"published_box_pushing_grid.png", "tables.md"}
    text = (results / "tables.md").read_text()
    assert "every 500 samples, 2 episodes, options sampled" in text
    assert "| bp6 (published) | Mac-IAICC | 5 | 21.3 ± 4.1 |" in text
    for run in discover_runs([tmp_path / "runs"]):
        with (run.path / "metrics.csv").open(newline="") as handle:
            rows = [r for r in csv.DictReader(handle) if r["eval_return"] != "nan"]
        last = [float(r["eval_return"]) for r in rows if float(r["samples"]) <= 3_000][-5:]
        assert f"seed{run.seed} {sum(last) / len(last):.1f} (" in text


def test_a_round_learner_read_at_the_published_cadence_keeps_every_sixth_rounds_evaluation():
    """``bench/analysis/seed_values.py --every-rounds 6`` on a committed 10x10 ACAC run: the
    number the Box Pushing page quotes for the authors' cadence, beside maopg's own."""
    root = Path(__file__).parents[2]
    run = root / "results/box-pushing-10/runs/box_pushing_grid/acac/seed1"
    script = [sys.executable, str(root / "bench/analysis/seed_values.py"), str(run)]
    script += ["--at", "100000", "--counter", PUBLISHED_COUNTER]
    rows = {}
    for every in ("1", "6"):
        out = subprocess.run([*script, "--every-rounds", every], capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        rows[every] = out.stdout.splitlines()[-1]
    assert rows["1"].endswith("| -18.0 |") and rows["6"].endswith("| 1.0 |")
