"""What a training run says: its progress in a log (a few lines, not a redrawn bar), the budget
its whole iterations round to, and its end — the final return and the final policy's
evaluation on the command line and in ``done.json``."""

from __future__ import annotations

import json

import pytest

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main
from maopg.experiment.training.trainer import rounding_note
from maopg.progress import LOG_LINES

SHORT = ["batch_ticks=60", "num_envs=2", "env.max_ticks=40", "video=false", "plot=false"]
"""A run of a few seconds whose episodes (40 ticks) end often."""


def test_a_run_in_a_log_prints_a_few_lines_and_ends_with_what_it_learnt(tmp_path, capsys):
    run_dir = tmp_path / "run"
    args = ["--total-samples", "600", *SHORT, "progress=true", "eval_episodes=2"]
    assert main([*args, "--run-dir", str(run_dir)]) == 0
    printed = capsys.readouterr()
    assert "\r" not in printed.err  # no redrawn bar: stderr is no terminal here
    progress = [line for line in printed.err.splitlines() if " ticks (" in line]
    assert 2 <= len(progress) <= LOG_LINES + 1, printed.err
    assert progress[-1].startswith("tool_delivery/async/seed0: ")
    assert "100%" in progress[-1] and "ret=" in progress[-1]
    done = json.loads((run_dir / "done.json").read_text())
    assert isinstance(done["final_return"], float)
    for kind in ("greedy", "sampled"):
        evaluated = done["evaluation"][kind]
        assert evaluated["episodes"] == 2 and 0 <= evaluated["success_rate"] <= 1
        assert f"final policy, {kind}: return {evaluated['return_mean']:.1f}, " in printed.out
    assert f"final return {done['final_return']:.1f} (the training episodes of the last 10%" in (
        printed.out
    )
    assert f"trained {done['samples']} samples in {done['iterations']} iterations" in printed.out
    last = printed.out.splitlines()[-1]
    assert last.startswith(f"run directory: {run_dir} (") and "final.pt, metrics.csv" in last


def test_a_run_without_evaluation_ends_with_its_final_return(tmp_path, capsys):
    run_dir = tmp_path / "run"
    args = ["--total-samples", "120", *SHORT, "progress=false", "eval_episodes=0"]
    assert main([*args, "--run-dir", str(run_dir)]) == 0
    out, err = capsys.readouterr()
    assert " ticks (" not in err  # progress=false
    done = json.loads((run_dir / "done.json").read_text())
    assert "evaluation" not in done and "final policy" not in out
    assert "final return" in out and out.splitlines()[-1].startswith("run directory:")


def test_the_training_bar_is_a_tqdm_bar_on_a_terminal(tmp_path, capsys, terminal):
    args = ["--total-samples", "120", *SHORT, "progress=true", "eval_episodes=0"]
    assert main([*args, "--run-dir", str(tmp_path / "run")]) == 0
    assert "tick/s" in capsys.readouterr().err  # tqdm's rate


@pytest.mark.parametrize(
    ("total", "samples", "ticks", "said"),
    [
        (3000, 2001, 2001, "total_samples 3000 → about 4002"),  # iterations of 2,000 ticks
        (30000, 206, 206, None),  # run.sh: 30,076 is within 1% of the budget
        (600, 62, 62, "total_samples 600 → about 620"),
    ],
)
def test_a_budget_off_the_iterations_is_said_once_at_the_start(total, samples, ticks, said):
    note = rounding_note(total, samples, ticks)
    assert note == said if said is None else note.startswith(said)


def test_a_run_says_where_its_budget_rounds_to(tmp_path, capsys):
    args = ["--total-samples", "90", *SHORT, "progress=false", "eval_episodes=0"]
    assert main([*args, "--run-dir", str(tmp_path / "run")]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "total_samples" in line]
    assert len(notes) == 1 and notes[0].startswith("note: total_samples 90 → about 12"), notes


def test_a_short_bar_prints_nothing_in_a_log(capsys):
    args = ["evaluate", "--reference", "random", "--episodes", "2", "env.max_ticks=20"]
    assert eval_main(args) == 0
    assert capsys.readouterr().err == ""
