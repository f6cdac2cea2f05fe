"""The whole run's ETA in the training bar (:mod:`maopg.experiment.training.eta`): the training
left plus the steps after it, from the rates the run measured."""

from __future__ import annotations

import re

import pytest

from maopg.env.video import VIDEO_MAX_TICKS
from maopg.experiment.cli.train_cli import main
from maopg.experiment.evaluation.evaluate import EVAL_MAX_TICKS
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.training.eta import (
    GIF_SECONDS_PER_FRAME,
    PLOT_SECONDS,
    SETUP_SECONDS,
    VIDEO_SECONDS_PER_FRAME,
    RunRates,
    about,
    estimate_run,
)

RATES = RunRates(samples_per_s=100.0, collecting_s=3.0, ticks=600, episode_length=120.0)
"""0.005 s a tick of the environments together; episodes of 120 ticks."""


def test_the_estimate_is_made_of_the_measured_rates():
    config = TrainConfig(total_samples=1000, backend="local", num_envs=2, eval_episodes=5)
    training, after = estimate_run(config, 400, RATES, max_ticks=150)
    assert training == pytest.approx(600 / 100.0)
    evaluation = 2 * 5 * 120 * 0.005
    video = 120 * 0.005 + (4 * 120 + 1) * VIDEO_SECONDS_PER_FRAME  # four frames a tick
    assert after == pytest.approx(SETUP_SECONDS + evaluation + video + PLOT_SECONDS)
    # the TensorBoard GIF, when asked for, reads every frame back
    gif = TrainConfig(total_samples=1000, backend="local", num_envs=2, video_gif=True)
    _, with_gif = estimate_run(gif, 400, RATES, max_ticks=150)
    assert with_gif == pytest.approx(after + (4 * 120 + 1) * GIF_SECONDS_PER_FRAME)
    # two threads step the 4 environments: one environment alone ticks at half the rate
    threads = TrainConfig(total_samples=1000, backend="threads", num_envs=4, video=False)
    _, after = estimate_run(threads, 400, RATES, max_ticks=150)
    assert after == pytest.approx(SETUP_SECONDS + 2 * 5 * 120 * 0.01 + PLOT_SECONDS)


def test_an_endless_task_is_estimated_at_the_bounds():
    """No episode ended yet and ``max_ticks`` is a billion: the evaluation and the video are
    estimated at their bounds, which is what they will play at most."""
    config = TrainConfig(
        total_samples=1000, backend="local", eval_episodes=1, plot=False, video=True
    )
    rates = RunRates(samples_per_s=50.0, collecting_s=1.0, ticks=1000, episode_length=None)
    training, after = estimate_run(config, 1000, rates, max_ticks=10**9)
    assert training == 0.0
    video = VIDEO_MAX_TICKS * 0.001 + (4 * VIDEO_MAX_TICKS + 1) * VIDEO_SECONDS_PER_FRAME
    assert after == pytest.approx(SETUP_SECONDS + 2 * EVAL_MAX_TICKS * 0.001 + video)


@pytest.mark.parametrize(
    ("seconds", "said"), [(0.4, "~0s"), (44.6, "~45s"), (190, "~3m10s"), (7500, "~2h05m")]
)
def test_the_estimate_is_said_as_one(seconds, said):
    assert about(seconds) == said


def test_the_training_bar_shows_when_the_whole_run_is_done(tmp_path, capsys):
    args = ["--seed", "1", "--total-samples", "120", "batch_ticks=60", "num_envs=2"]
    args += ["progress=true", "video=false", "plot=false", "eval_episodes=1"]
    assert main([*args, "--run-dir", str(tmp_path / "run")]) == 0
    err = capsys.readouterr().err
    assert re.search(r"run done in ~\d+s", err), err
    assert re.search(r"note: after training \(estimated ~\d+s\): evaluation of 2 x 1", err)
