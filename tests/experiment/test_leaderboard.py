"""The leaderboard (maopg.experiment.studies.leaderboard): its boards reuse the studies' runs
at their settings, its protocol reads every run alike, and a tiny leaderboard trains what no
study runs and writes its tables, scores and profile."""

from __future__ import annotations

import csv
import math
import re
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from maopg.experiment.studies import Study, StudyTask, frozen, get_study, registry
from maopg.experiment.studies.builtin import FEW_EPISODES
from maopg.experiment.studies.grid import Cell, cell_config
from maopg.experiment.studies.leaderboard import (
    AGENT_METHODS,
    BOARDS,
    TUNING,
    Board,
    Entry,
    aggregate_table,
    board_runs,
    entries,
    evaluated_budget,
    headline_table,
    headline_usage,
    pilot_budgets,
    reproduce_leaderboard,
)
from maopg.experiment.studies.option_usage import usage_table
from maopg.experiment.studies.runs import RunData
from maopg.experiment.studies.stats import iqm


def test_the_boards_are_the_issues_tasks_at_their_studies_settings():
    assert [b.name for b in BOARDS] == [
        "tool_delivery",
        "water_filling",
        "box_pushing_grid_6",
        "box_pushing_grid_10",
        "box_pushing",
        "tool_delivery_8_masked",
        "tool_delivery_8",
        "water_filling_8",
    ]
    for board in BOARDS:
        source = get_study(board.study).task(board.task)
        assert source.threshold is not None
        assert all(m in TUNING for m in board.methods), board.name
        for method, home in board.reuse.items():
            # A reused study's runs are the same experiment: task settings, seeds, budget.
            other = get_study(home).task(board.task)
            assert (other.settings, other.seeds) == (source.settings, source.seeds)
            assert dict(get_study(home).overrides).get("total_samples") == dict(
                get_study(board.study).overrides
            ).get("total_samples")
            assert method in get_study(home).methods or method in get_study(home).baselines
    # the Box Pushing tasks' training defaults explore for the MAPPO family, and the label says so
    by_name = {b.name: b for b in BOARDS}
    for name in ("box_pushing_grid_6", "box_pushing"):
        assert by_name[name].tuning_of("async") == "maopg defaults, the grid's exploration"
        assert by_name[name].tuning_of("mac-dqn") == "maopg defaults"
    assert by_name["tool_delivery"].tuning_of("async") == "maopg defaults"


def test_the_literature_methods_take_their_few_episode_settings_off_box_pushing(tmp_path):
    """On the boards whose budgets hold hundreds of episodes ACAC and Mac-IAICC train with
    their few-episode settings, labelled so; on Box Pushing with their published ones."""
    for board in BOARDS:
        few = not board.task.startswith("box_pushing")
        for method in AGENT_METHODS:
            assert (board.tuning_of(method) == "few-episode settings") == few, board.name
            assert (board.method_overrides.get(method) == FEW_EPISODES[method]) == few
    board = BOARDS[0]
    ((study, root, _),) = [g for g in board.grids(tmp_path) if "acac" in g[2]]
    acac = cell_config(Cell(board.task, "acac", 0), root, study)[0]
    mac = cell_config(Cell(board.task, "mac-iaicc", 0), root, study)[0]
    assert (acac.learner.clip, acac.learner.train_repeat, acac.learner.explore_decay) == (
        0.2,
        10,
        50,
    )
    assert (mac.learner.n_step, mac.learner.episodes_per_update) == (5, 4)


@pytest.mark.parametrize("board", [b for b in BOARDS if "_8" in b.name], ids=lambda b: b.name)
def test_the_teams_of_eight_rank_no_product_categorical(board):
    """At team size 8 a head over the joint options (15.3M on Tool Delivery) is refused before
    it is built (maopg.policy.joint_size): the team boards rank only methods whose policies
    factor over the robots."""
    assert not {"async", "sync-cut", "sync-wait", "partial", "end2end", "mac-dqn"} & set(
        board.methods
    )


def _run(method: str, samples: np.ndarray, evaluations: np.ndarray, training: float) -> RunData:
    """A finished run of ``method`` on the grid logging ``evaluations`` (``nan``: none that
    iteration) and a training return of ``training`` throughout."""
    metrics = {"episode_return": np.full(samples.size, training), "eval_return": evaluations}
    return RunData(Path("-"), "box_pushing_grid", method, 0, samples, metrics, True, {})


def test_a_board_that_evaluates_reads_every_run_at_its_budget_from_the_evaluations():
    """On the 6x6 board (budget 500K, threshold 200): an ``async`` run's evaluations reach 299
    by 300K while its ε-mixed training episodes read 39; an ``acac`` run that trains on to 2.5M
    evaluates 39 up to 500K and 299 after it — it is read at 500K, 39, not at its end; one still
    training is read where it stands."""
    board = next(b for b in BOARDS if b.name == "box_pushing_grid_6")
    assert evaluated_budget(board) == 500_000
    assert evaluated_budget(BOARDS[0]) is None  # Tool Delivery: no evaluation logged
    at = np.arange(1, 11) * 50_000.0
    paper = _run("async", at, np.where(at >= 300_000, 299.0, 39.0), 39.0)
    at_long = np.arange(1, 51) * 50_000.0
    acac = _run("acac", at_long, np.where(at_long > 500_000, 299.0, 39.0), 299.0)
    young = replace(_run("async", at[:4], np.full(4, 20.0), 20.0), finished=False, seed=1)
    rows = entries(board, [paper, acac, young], (0.0, 300.0))
    assert [(e.method, e.final_return, e.samples) for e in rows] == [
        ("async", 299.0, 500_000),
        ("acac", 39.0, 500_000),
        ("async", 20.0, 200_000),
    ]
    assert rows[0].score == pytest.approx(299.0 / 300.0)
    # the trailing mean of 5 evaluations passes 200 at the fourth at 299: 450K
    assert (rows[0].to_threshold, math.isnan(rows[1].to_threshold)) == (450_000, True)


def _entry(board: str, method: str, seed: int, score: float) -> Entry:
    return Entry(board, method, seed, score * 100, score, math.nan, True)


def test_the_aggregate_is_the_iqm_over_a_methods_boards():
    boards = [Board("a", "paper", "tool_delivery", ("x", "y")), Board("b", "paper", "x", ("x",))]
    rows = [_entry("a", "x", s, v) for s, v in enumerate((0.0, 1.0, 2.0, 3.0))]
    rows += [_entry("b", "x", s, v) for s, v in enumerate((10.0, 10.0))]
    rows += [_entry("a", "y", s, v) for s, v in enumerate((0.5, 0.5))]
    table = aggregate_table(boards, rows).splitlines()
    # x over its two boards: IQM of (0, 1, 2, 3, 10, 10) = mean(1, 2, 3, 10): a quarter is 1.
    assert iqm(np.array([0.0, 1.0, 2.0, 3.0, 10.0, 10.0])) == pytest.approx(4.0)
    assert table[2].startswith("| x | 2 | 4.00 [")
    assert table[3] == "| y | 1 | 0.50 [0.50, 0.50] |"


def test_the_headline_sets_the_papers_policy_against_the_literatures_on_the_boards_all_share():
    """The paper's policy is ``async`` where a board ranks it and ``async-ar`` on a team board;
    a board where one of the three has no runs is left out of the comparison and named."""
    methods = ("async", "async-ar", *AGENT_METHODS)
    boards = [
        Board("small", "paper", "tool_delivery", methods),
        Board("team", "teams", "tool_delivery", methods[1:]),
        Board("new", "paper", "water_filling", methods),
    ]
    rows = [_entry("small", "async", s, v) for s, v in enumerate((0.9, 1.0))]
    rows += [_entry("small", "async-ar", s, 0.0) for s in range(2)]  # not the headline's
    rows += [_entry("team", "async-ar", s, v) for s, v in enumerate((0.2, 0.4))]
    rows += [_entry(b, m, s, 0.5) for b in ("small", "team") for m in AGENT_METHODS for s in (0, 1)]
    rows += [_entry("new", "async", 0, 1.0)]
    table = headline_table(boards, rows).splitlines()
    assert table[0] == (
        "|  | IQM normalised, the 2 boards all three share [95 % CI] | small | team |"
    )
    # the paper's policy: IQM of (0.2, 0.4, 0.9, 1.0) = mean(0.4, 0.9)
    assert table[2].startswith("| the paper's policy | 0.65 [")
    assert table[2].endswith("| 0.95 (`async`) | 0.30 (`async-ar`) |")
    assert table[3] == "| acac | 0.50 [0.50, 0.50] | 0.50 | 0.50 |"
    assert table[-1] == "Boards where one of the three has no runs yet: new."


def test_a_tiny_leaderboard_trains_what_no_study_runs_and_reads_the_rest(tmp_path, monkeypatch):
    """A study with ``async`` on Tool Delivery (2 seeds, 1,500 samples); its board also ranks
    ``sync-cut``, which the study does not run: the leaderboard trains it in its own folder,
    trains the study's cells in the study's, and writes one row per method."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(registry, "_STUDIES", dict(registry._STUDIES))  # registered here only
    tiny = Study(
        "tiny",
        "-",
        (StudyTask("tool_delivery", (0, 1), threshold=-1000.0),),
        ("async",),
        frozen({"total_samples": 1_500, "batch_ticks": 500, "plot": False}),
    )
    registry.register_study("tiny", lambda: tiny)
    monkeypatch.setitem(TUNING, "sync-cut", "-")
    board = Board("td", "tiny", "tool_delivery", ("async", "sync-cut"))
    settings = {"in_process": True, "reference_episodes": 2, "usage_episodes": 2}
    outcomes, written = reproduce_leaderboard(
        tmp_path / "lb", boards=[board], log=lambda _: None, **settings
    )
    assert sorted(outcomes.values()) == ["done"] * 4
    assert (tmp_path / "results/tiny/runs/tool_delivery/async/seed1/done.json").exists()
    assert (tmp_path / "lb/runs/td/tool_delivery/sync-cut/seed1/done.json").exists()
    assert {p.name for p in written} == {
        "tables.md",
        "scores.csv",
        "performance_profile.png",
        "performance_profile.svg",
    }
    with (tmp_path / "lb/scores.csv").open(newline="") as handle:
        scores = list(csv.DictReader(handle))
    assert sorted((r["method"], r["seed"]) for r in scores) == [
        ("async", "0"),
        ("async", "1"),
        ("sync-cut", "0"),
        ("sync-cut", "1"),
    ]
    assert all(r["samples_to_threshold"] != "nan" for r in scores)  # −1000: reached at once
    text = (tmp_path / "lb/tables.md").read_text()
    assert "| async | maopg defaults | 2 | 2K |" in text and "| sync-cut | - | 2 | 2K |" in text
    # samples to the threshold in one unit, the mean and its interval alike
    assert re.search(r"\| \d+\.\dK( \[\d+\.\dK, \d+\.\dK\])? \(2 of 2\) \|", text), text
    assert "Boards where one of the three has no runs yet: td." in text  # no acac, mac-iaicc
    assert "### What their policies do\n\nOn the boards" in text and "No board yet." in text
    # What the headline's seed-0 policy does (sync-cut is not the headline's): a line per agent.
    runs = board_runs(board, tmp_path / "lb/runs")
    read = entries(board, runs, None)
    (usage,) = headline_usage(board, runs, 2, read)
    assert usage[:2] == ("td", "async") and usage[2]["episodes"] == 2
    assert usage[3] == next(e.final_return for e in read if (e.method, e.seed) == ("async", 0))
    assert set(usage[2]["choices"]) == {"turtlebot0", "turtlebot1", "fetch"}
    assert (tmp_path / "results/tiny/runs/tool_delivery/async/seed0/option_usage.json").exists()
    line = usage_table([usage]).splitlines()[2]
    assert re.match(
        r"\| td \| `async` \| -?\d+\.\d \| -?\d+\.\d \| \d+% \| [\d.]+ \| turtlebot0 \| "
        r"\d+ choices — ",
        line,
    )
    # A second call trains nothing and writes the same tables.
    again, _ = reproduce_leaderboard(
        tmp_path / "lb", boards=[board], log=lambda _: None, **settings
    )
    assert set(again.values()) == {"skipped"}
    assert (tmp_path / "lb/tables.md").read_text() == text
    # The tuning budget behind a piloted label is counted from the logged pilot runs.
    assert pilot_budgets(tmp_path / "lb") == ""
    trained = tmp_path / "results/tiny/runs/tool_delivery/async"
    for seed in (0, 1):
        shutil.copytree(trained / f"seed{seed}", tmp_path / f"lb/pilots/p{seed}/seed{seed}")
    # an exploration pilot on Tool Delivery chose no label's settings: it is not counted
    shutil.copytree(trained / "seed0", tmp_path / "exploration/pilots/td/seed0")
    assert pilot_budgets(tmp_path / "lb") == (
        " Tuning budgets, counted from the logged pilot runs (settings tried, runs, samples): "
        "*few-episode settings* — `async` 2 pilots, 2 runs, 3.0K samples on tool_delivery."
    )
