"""Learning smoke: MAPPO on Tool Delivery (state observations) learns, seeded, with the
autoregressive conditional (``async-ar``) and with a GRU over the option-level history in policy
and critic (``async-rnn``); the product categorical (``async``) is the main job's, whose test
(``tests/test_main_job.py``) asserts more of it: its 60K-sample policy succeeds greedy and sampled.

Each budget leaves the uniform-random policy (≈ −57 over the test's 40 episodes) far behind: the
episode-weighted mean return over the last fifth of training, measured for seeds 0, 1 and 2
(the test runs seed 0), was for ``async-ar`` 228.7, 240.0 and 228.6 at 15K samples (190.5,
219.3 and 214.4 at 10K); the recurrent policy learns more slowly at first, 208.3, 228.9 and
218.6 at 30K (188.9, 216.4 and 209.6 at 25K). On the Box Pushing grid, ``async`` learns the
small boxes within 10K samples.
"""

import numpy as np
import pytest

from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import read_metrics
from maopg.experiment.training.trainer import train
from maopg.learner import PPOConfig

BUDGET = {"async-ar": 15_000, "async-rnn": 30_000}


@pytest.mark.slow
@pytest.mark.parametrize("method", list(BUDGET))
def test_async_beats_the_random_policy_by_a_wide_margin(tmp_path, method, random_tool_delivery):

    config = TrainConfig(
        task="tool_delivery",
        method=method,
        seed=0,
        total_samples=BUDGET[method],
        progress=False,
        video=False,
        eval_episodes=0,
        plot=False,
        run_dir=str(tmp_path / "run"),
    )
    rows = read_metrics(train(config) / "metrics.csv")
    # Episode-weighted mean return over the last fifth of training.
    late = [r for r in rows if int(r["samples"]) > 0.8 * BUDGET[method] and int(r["episodes"]) > 0]
    episodes = np.array([int(r["episodes"]) for r in late])
    returns = np.array([float(r["episode_return"]) for r in late])
    trained_mean = float((episodes * returns).sum() / episodes.sum())

    assert episodes.sum() >= 20
    assert trained_mean > random_tool_delivery + 200, (trained_mean, random_tool_delivery)


@pytest.mark.slow
def test_async_beats_the_random_team_on_the_box_pushing_grid(tmp_path, random_grid4):
    """4x4 Box Pushing, 10K samples, without the task's default exploration (whose training
    episodes are all but random this early): ``async`` learns to push a small box (19.6)
    within them, where a random team averages about 1.6 over these 200 episodes. Measured
    here, the mean return over the last fifth of training was 15.9, 15.6 and 14.2 for seeds 0,
    1 and 2 (the big box, 299.6, is not found in this budget: the exploration problem of the
    benchmark, docs/results/exploration.md)."""
    budget = 10_000
    config = TrainConfig(
        task="box_pushing_grid",
        method="async",
        seed=0,
        total_samples=budget,
        progress=False,
        video=False,
        eval_episodes=0,
        plot=False,
        env_overrides={"size": 4},
        run_dir=str(tmp_path / "run"),
        learner=PPOConfig(),
    )
    rows = read_metrics(train(config) / "metrics.csv")
    late = [r for r in rows if int(r["samples"]) > 0.8 * budget and int(r["episodes"]) > 0]
    episodes = np.array([int(r["episodes"]) for r in late])
    returns = np.array([float(r["episode_return"]) for r in late])
    trained_mean = float((episodes * returns).sum() / episodes.sum())
    assert trained_mean > random_grid4 + 8, (trained_mean, random_grid4)
