"""A user's first mistakes with settings (issue #46), met where the user meets them: an unknown
setting names the nearest known one, a setting out of range or at odds with another says what
is allowed, before anything is built or written; and ``eval``'s ``--threshold`` leaves the run
directories after it alone."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from maopg.experiment.cli.eval_cli import build_parser as eval_parser
from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import DONE
from maopg.experiment.run.methods import Method, register_method
from maopg.learner import ACACConfig, MacDQNConfig
from maopg.learner.mac_iaicc import MacIAICCConfig
from maopg.options.base import Strategy

REPO = Path(__file__).resolve().parents[2]


def _one_line(err: str, line: str) -> None:
    assert err.strip().splitlines() == [line], err


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (["ppo.epoch=3"], "unknown setting 'ppo.epoch': did you mean 'ppo.epochs'?"),
        (["num_env=3"], "unknown setting 'num_env': did you mean 'num_envs'?"),
        (["max_tick=3"], "unknown setting 'max_tick': did you mean 'env.max_ticks'?"),
        (["pp.epochs=3"], "unknown setting 'pp.epochs': did you mean 'ppo.epochs'?"),
        (
            ["env.max_tick=3"],
            "unknown setting 'env.max_tick' of task 'tool_delivery': did you mean 'env.max_ticks'?",
        ),
        (
            ["--method", "mac-dqn", "dqn.buffer=9"],
            "unknown setting 'dqn.buffer': did you mean 'dqn.buffer_size'?",
        ),
    ],
)
def test_an_unknown_setting_names_the_nearest_and_writes_nothing(argv, line, tmp_path, capsys):
    run_dir = tmp_path / "run"
    assert train_main([*argv, "--run-dir", str(run_dir)]) == 2
    _one_line(capsys.readouterr().err, f"python -m train: error: {line}")
    assert not run_dir.exists()


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("ppo:\n  epoch: 3\n", "unknown setting 'ppo.epoch': did you mean 'ppo.epochs'?"),
        ("ppo.epoch: 3\n", "unknown setting 'ppo.epoch': did you mean 'ppo.epochs'?"),
        ("num_env: 3\n", "unknown setting 'num_env': did you mean 'num_envs'?"),
        (
            "env:\n  max_tick: 3\n",
            "unknown setting 'env.max_tick' of task 'tool_delivery': did you mean 'env.max_ticks'?",
        ),
    ],
)
def test_an_unknown_key_of_a_config_file_names_the_nearest(text, line, tmp_path, capsys):
    config = tmp_path / "run.yaml"
    config.write_text(text)
    run_dir = tmp_path / "run"
    assert train_main(["--config", str(config), "--run-dir", str(run_dir)]) == 2
    _one_line(capsys.readouterr().err, f"python -m train: error: {line}")
    assert not run_dir.exists()


def test_evaluate_names_the_nearest_task_setting(capsys):
    argv = ["evaluate", "--reference", "random", "--episodes", "1", "env.max_tick=3"]
    assert eval_main(argv) == 2
    _one_line(
        capsys.readouterr().err,
        "python -m eval: error: unknown setting 'env.max_tick' of task 'tool_delivery': did you "
        "mean 'env.max_ticks'?",
    )


def test_strategy_is_no_setting_and_an_unknown_one_lists_them(capsys):
    assert train_main(["strategy=any"]) == 2
    err = capsys.readouterr().err
    assert "strategy is no setting: the method brings it" in err
    assert "any (--method sync-cut / sync-cut-ar)" in err
    known = "the strategies are: continue, any, all, primitive"
    with pytest.raises(ValueError, match=f"^unknown strategy 'sync'; {known}$"):
        Strategy("sync")
    method = Method("mine", "sync", "maopg.learner.mappo:MAPPOLearner", "m:f", config=MacDQNConfig)
    with pytest.raises(ValueError, match=f"unknown strategy 'sync'; {known}"):
        register_method(method)


def test_too_many_workers_is_an_error_naming_the_range():
    with pytest.raises(
        ValueError,
        match=r"^num_workers=10000 is more than num_envs=4: a worker steps one environment at "
        r"least, so num_workers may be 0 \(the backend's default\) to 4$",
    ):
        TrainConfig(num_workers=10000).resolved()
    assert TrainConfig(num_workers=4, backend="processes").resolved().num_workers == 4


def test_a_replay_that_cannot_hold_an_episode_is_refused_before_anything_runs():
    small = TrainConfig(method="mac-dqn", learner=MacDQNConfig(buffer_size=100))
    with pytest.raises(
        ValueError,
        match=r"^dqn\.buffer_size=100 cannot hold one episode of env\.max_ticks=150 ticks: set "
        r"dqn\.buffer_size >= 150 or env\.max_ticks <= 100$",
    ):
        small.resolved()
    small.env_overrides["max_ticks"] = 100
    assert small.resolved().learner.buffer_size == 100


def test_critics_of_the_state_are_refused_on_a_task_without_one():
    config = TrainConfig(method="mac-iaicc", learner=MacIAICCConfig(critic="state"))
    with pytest.raises(ValueError, match=r"^maciaicc\.critic=state reads the task's global state"):
        config.resolved()
    config.task = "box_pushing_grid"
    assert config.resolved().learner.critic == "state"


def test_the_round_learners_sections_check_their_bounds():
    with pytest.raises(ValueError, match=r"^acac\.lr must be > 0, got -1\.0$"):
        ACACConfig(lr=-1.0)
    with pytest.raises(ValueError, match=r"^maciaicc\.critic must be one of .*, got 'nope'$"):
        MacIAICCConfig(critic="nope")
    with pytest.raises(ValueError, match=r"^acac\.width \(30\) must be a multiple of acac\.heads"):
        ACACConfig(width=30, heads=4)


@pytest.mark.parametrize(("script", "usage"), [("maopg-train", "train"), ("maopg-eval", "eval")])
def test_the_installed_scripts_usage_names_them(script, usage, tmp_path):
    """A console script calls ``main()`` with its own name in ``sys.argv[0]``."""
    path = tmp_path / script
    path.write_text(
        f"import sys\nfrom maopg.experiment.cli.{usage}_cli import main\nsys.exit(main())\n"
    )
    done = subprocess.run(
        [sys.executable, str(path), "--help"],
        capture_output=True,
        text=True,
        check=True,
        cwd=REPO,
        env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"},
    )
    assert done.stdout.startswith(f"usage: {script} ")
    assert f"python -m {usage}" not in done.stdout.split("\n\n")[0]


def _finished_run(root: Path, method: str, seed: int, returns: list[float]) -> None:
    run_dir = root / "tool_delivery" / method / f"seed{seed}"
    run_dir.mkdir(parents=True)
    config = {"task": "tool_delivery", "method": method, "seed": seed}
    (run_dir / "config.json").write_text(json.dumps(config))
    with (run_dir / "metrics.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["iteration", "samples", "episode_return", "option_step_reward"])
        for k, value in enumerate(returns, 1):
            writer.writerow([k, 100 * k, value, value / 10])
    (run_dir / DONE).write_text("{}")


@pytest.mark.parametrize(
    "argv",
    [
        ["--threshold", "tool_delivery=50", "RUNS"],
        ["--threshold=tool_delivery=50", "--threshold", "water_filling=-9", "RUNS"],
        ["RUNS", "--threshold", "tool_delivery=50", "water_filling=-9"],
        ["--threshold", "tool_delivery=50", "water_filling=-9", "RUNS"],
        ["--threshold", "tool_delivery=50", "water_filling=-9", "--", "RUNS"],
    ],
)
def test_table_takes_its_runs_after_a_threshold(argv, tmp_path, capsys):
    root = tmp_path / "runs"
    _finished_run(root, "async", 0, [10.0, 60.0, 40.0])
    argv = [str(root) if item == "RUNS" else item for item in argv]
    assert eval_main(["table", "--window", "1", *argv]) == 0
    assert "| tool_delivery | async | 50 | 200 | 1/1 |" in capsys.readouterr().out


def test_reproduce_keeps_every_threshold():
    argv = ["reproduce", "--threshold", "tool_delivery=50", "--threshold", "water_filling=-9"]
    assert eval_parser().parse_args(argv).threshold == ["tool_delivery=50", "water_filling=-9"]
