"""A user's first mistakes with settings (issue #46), met where the user meets them: an unknown
setting names the nearest known one, a setting out of range or at odds with another says what
is allowed, before anything is built or written."""

from __future__ import annotations

import pytest

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.methods import Method, register_method
from maopg.learner import ACACConfig, MacDQNConfig
from maopg.learner.mac_iaicc import MacIAICCConfig
from maopg.options.base import Strategy


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


def test_the_round_learners_sections_check_their_bounds():
    with pytest.raises(ValueError, match=r"^acac\.lr must be > 0, got -1\.0$"):
        ACACConfig(lr=-1.0)
    with pytest.raises(ValueError, match=r"^maciaicc\.critic must be one of .*, got 'nope'$"):
        MacIAICCConfig(critic="nope")
    with pytest.raises(ValueError, match=r"^acac\.width \(30\) must be a multiple of acac\.heads"):
        ACACConfig(width=30, heads=4)
