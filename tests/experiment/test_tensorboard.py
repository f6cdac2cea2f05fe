"""What a run shows in TensorBoard besides the training curves: its settings (HPARAMS), the
option choices per agent at every iteration, the final policy's evaluation and the rollout."""

from __future__ import annotations

import math
import re

import pytest
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from maopg.experiment.cli.train_cli import main as train_main

SHORT = ["batch_ticks=60", "num_envs=2", "env.max_ticks=30", "ppo.epochs=1", "plot=false"]


@pytest.fixture(scope="module")
def events(tmp_path_factory) -> EventAccumulator:
    run_dir = tmp_path_factory.mktemp("tb") / "run"
    args = ["--task", "tool_delivery", "--total-samples", "120", "--run-dir", str(run_dir)]
    assert train_main([*args, *SHORT, "progress=false", "eval_episodes=2", "video_gif=true"]) == 0
    accumulator = EventAccumulator(str(run_dir / "tb"), size_guidance={"images": 0, "scalars": 0})
    accumulator.Reload()
    return accumulator


def test_settings_are_in_the_hparams_tab(events):
    content = events.PluginTagToContent("hparams")
    assert "_hparams_/session_start_info" in content
    start = content["_hparams_/session_start_info"].decode(errors="ignore")
    assert "ppo.ent_coef" in start and "tool_delivery" in start
    assert "eval/return_greedy" in content["_hparams_/experiment"].decode(errors="ignore")


def test_option_choices_are_logged_per_agent_each_iteration(events):
    steps = [e.step for e in events.Scalars("train/policy_loss")]
    assert len(steps) == 2
    shares = [t for t in events.Tags()["scalars"] if t.startswith("options/fetch/")]
    assert len(shares) == 6  # SearchTool(0..2), PassTo(0, 1), Wait: every Fetch option
    for step in steps:
        total = sum(next(e.value for e in events.Scalars(t) if e.step == step) for t in shares)
        assert math.isclose(total, 1.0, rel_tol=1e-6)


def test_the_final_policy_is_evaluated_and_filmed_with_the_gif_asked_for(events):
    (greedy,) = events.Scalars("eval/return_greedy")
    (sampled,) = events.Scalars("eval/return_sampled")
    assert greedy.step == sampled.step >= 120
    assert -30.0 <= greedy.value <= 300.0 and -330.0 <= sampled.value <= 300.0
    assert any(t.startswith("eval_options_greedy/turtlebot0/") for t in events.Tags()["scalars"])
    (video,) = events.Images("rollout")
    assert video.encoded_image_string[:4] == b"GIF8" and video.width > 100


def test_after_training_announces_its_steps_and_shows_their_progress(tmp_path, capfd, terminal):
    run_dir = tmp_path / "run"
    args = ["--task", "tool_delivery", "--total-samples", "30", "--run-dir", str(run_dir)]
    tiny = ["batch_ticks=30", "num_envs=1", "env.max_ticks=8", "ppo.epochs=1", "plot=false"]
    assert train_main([*args, *tiny, "eval_episodes=1"]) == 0
    err = capfd.readouterr().err
    plan = re.search(
        r"after training \(estimated ~\d+s\): evaluation of 2 x 1 episodes \(greedy, sampled\), "
        "a rollout video",
        err,
    )
    assert plan, err
    for bar in ("evaluating eval/return_greedy", "video rollout.mp4"):
        assert bar in err, bar
    assert plan.start() < err.index("video rollout.mp4")
    # the TensorBoard GIF is opt-in (video_gif): none by default
    assert "GIF" not in err
    events = EventAccumulator(str(run_dir / "tb"), size_guidance={"images": 0})
    events.Reload()
    assert "rollout" not in events.Tags()["images"]
