"""Learning smoke of the literature's methods (``acac``, ``mac-iaicc``): on the 4x4 Box Pushing
grid and on Tool Delivery each beats a random team it measures, at settings sized for a
test's budget (each test says which and what it measured)."""

import pytest

from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import read_metrics
from maopg.experiment.studies.builtin import FEW_EPISODES
from maopg.experiment.training.trainer import train
from maopg.learner import ACACConfig
from maopg.learner.mac_iaicc import MacIAICCConfig


def _evaluations(tmp_path, **settings) -> list[float]:
    """Train a run of ``settings`` (no video, plot or final evaluation) and return its
    evaluations during training."""
    config = TrainConfig(
        progress=False,
        video=False,
        eval_episodes=0,
        plot=False,
        run_dir=str(tmp_path / "run"),
        **settings,
    )
    rows = read_metrics(train(config) / "metrics.csv")
    return [float(r["eval_return"]) for r in rows if r["eval_return"] != "nan"]


GRID_LEARNERS = {
    "acac": (ACACConfig(explore_decay=2_000), 10.0),
    "mac-iaicc": (MacIAICCConfig(explore_decay=500, episodes_per_update=8), 5.0),
}
"""The literature's methods on the 4x4 grid: each one's settings for a 20K-sample budget and the
margin over the random team its evaluation must clear (the test below)."""


@pytest.mark.slow
@pytest.mark.parametrize("method", list(GRID_LEARNERS))
def test_the_literature_methods_beat_the_random_team_on_the_box_pushing_grid(
    tmp_path, method, random_grid4
):
    """ACAC and Mac-IAICC on 4x4 Box Pushing, 20K samples: the policy each evaluates (sampled,
    no ε, 20 episodes) pushes the small boxes, where a random team averages about 1.6.

    ACAC's ε falls over 2,000 episodes (not its published 30,000: this budget is about 4,000
    episodes); measured here at 20K samples: 36.4, 19.1 and 30.4 for seeds 0, 1 and 2 (about
    20 s a run). Mac-IAICC trains on 8 episodes a round (not MacroMARL's 32: this budget is
    about 1,000 episodes), its ε falling over 500: 11.5, 7.4 and 14.1, rising at every
    evaluation (with 32 episodes a round and ε over 2,000 episodes: 1.5, 2.3 and 1.8, no better
    than random)."""
    learner, margin = GRID_LEARNERS[method]
    evaluated = _evaluations(
        tmp_path,
        task="box_pushing_grid",
        method=method,
        seed=0,
        total_samples=20_000,
        eval_every=5_000,
        eval_during_episodes=20,
        env_overrides={"size": 4},
        learner=learner,
    )
    assert evaluated[-1] > random_grid4 + margin, (evaluated, random_grid4)


TOOL_DELIVERY_LEARNERS = {"acac": (1, 10_000, 10, 100.0), "mac-iaicc": (1, 30_000, 40, 30.0)}
"""The literature's methods on Tool Delivery at their few-episode settings (the leaderboard's:
:data:`~maopg.experiment.studies.builtin.FEW_EPISODES`): each one's seed, budget, the episodes
of its one evaluation at the budget and the margin over the random team that evaluation must
clear (the test below)."""


@pytest.mark.slow
@pytest.mark.parametrize("method", list(TOOL_DELIVERY_LEARNERS))
def test_the_literature_methods_beat_the_random_team_on_tool_delivery(
    tmp_path, method, random_tool_delivery
):
    """ACAC and Mac-IAICC on Tool Delivery (state): the policy each evaluates at the end of its
    budget (sampled, no ε) beats a random team's mean (−57.3 over these 40 episodes) by the
    margin. Measured as the test measures, seeds 0, 1, 2: ACAC at 10K, 10 episodes, 32.0, 168.5
    and 134.0. Mac-IAICC learns far more slowly — one vanilla policy-gradient step a round — and
    unevenly: at 30K, 40 episodes (SE about 21), −8.5, 1.2 and −5.5, each about 50–60 above the
    random team. With one-step targets and rate 1e-3 it was worse than random in the pilots
    (docs/results/leaderboard.md): its turtlebots re-chose the one-tick move to where they
    stood, which a young critic's values near 0 make look best when every tick costs."""
    seed, budget, episodes, margin = TOOL_DELIVERY_LEARNERS[method]
    settings = {k.split(".", 1)[1]: v for k, v in FEW_EPISODES[method].items()}
    learner = ACACConfig(**settings) if method == "acac" else MacIAICCConfig(**settings)
    evaluated = _evaluations(
        tmp_path,
        task="tool_delivery",
        method=method,
        seed=seed,
        total_samples=budget,
        eval_every=budget,
        eval_during_episodes=episodes,
        learner=learner,
    )
    assert evaluated[-1] > random_tool_delivery + margin, (evaluated, random_tool_delivery)
