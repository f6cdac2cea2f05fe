"""Exploration by ε-mixed sampling in whole runs (``ppo.explore_*``): the same seed gives the same
curve, a killed run resumes bit for bit (the finished-episode count that ``explore_unit=episodes``
reads is in the checkpoint), the logged ε follows the schedule, and configs written before the
mechanism existed load with it off."""

from __future__ import annotations

import csv
import itertools
import json
from pathlib import Path

import pytest

from maopg.experiment.cli.train_cli import main, parse_args
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.experiment.run.migration import SCHEMA_KEY
from maopg.learner import load_checkpoint

RUN = ["--task", "box_pushing_grid", "env.size=4", "batch_ticks=60", "num_envs=2"]
RUN += ["backend=local", "progress=false", "video=false", "eval_episodes=0", "plot=false"]
RUN += ["checkpoint_every=2", "ppo.epochs=2", "--seed", "3"]
SAMPLES = ["ppo.explore_eps=0.9", "ppo.explore_eps_end=0.1", "ppo.explore_decay=300"]
SAMPLES += ["ppo.explore_unit=samples"]
EXPLORE = {
    "samples": [*SAMPLES, "ppo.explore_form=agent"],
    "joint": [*SAMPLES, "ppo.explore_form=joint", "ppo.explore_ratio=policy"],
    "episodes": [
        "ppo.explore_eps=1.0",
        "ppo.explore_eps_end=0.2",
        "ppo.explore_decay=20",
        "ppo.explore_unit=episodes",
        "ppo.explore_form=agent",
    ],
}
"""Every setting given: the grid's training defaults explore (ACAC's schedule, the joint)."""


def _run(run_dir: Path, samples: int, *extra: str) -> list[dict[str, str]]:
    """A run of ``samples``: without exploration unless ``extra`` sets ``ppo.explore_eps``."""
    if not any(e.startswith("ppo.explore_eps=") for e in extra):
        extra = (*extra, "ppo.explore_eps=0.0")
    args = [*RUN, "--total-samples", str(samples), "--run-dir", str(run_dir), *extra]
    assert main(args) == 0
    with (run_dir / "metrics.csv").open() as handle:
        return [
            {k: v for k, v in row.items() if k not in TIMING_COLUMNS}
            for row in csv.DictReader(handle)
        ]


@pytest.mark.parametrize("unit", ["samples", "episodes", "joint"])
def test_exploration_is_deterministic_and_resumes_exactly(tmp_path, unit):
    """Each schedule unit, and the joint form with the policy's ratio (on a samples schedule)."""
    whole = _run(tmp_path / "whole", 480, *EXPLORE[unit])
    again = _run(tmp_path / "again", 480, *EXPLORE[unit])
    assert whole == again
    _run(tmp_path / "resumed", 240, *EXPLORE[unit])
    resumed = _run(tmp_path / "resumed", 480, *EXPLORE[unit], "--resume")
    assert resumed == whole
    epsilon = [float(r["epsilon"]) for r in whole]
    assert epsilon[0] == (1.0 if unit == "episodes" else 0.9)
    assert all(a >= b for a, b in itertools.pairwise(epsilon)) and epsilon[-1] < 0.9
    if unit != "episodes":  # ε after s samples: 0.9 - 0.8 * min(s / 300, 1)
        starts = [0] + [int(r["samples"]) for r in whole[:-1]]
        assert epsilon == pytest.approx([0.9 - 0.8 * min(s / 300, 1) for s in starts])
    else:
        episodes = sum(int(r["episodes"]) for r in whole)
        state = load_checkpoint(tmp_path / "whole" / "checkpoint.pt")
        assert state["episodes"] == episodes


def test_exploration_changes_what_is_collected_and_off_is_the_policy_itself(tmp_path):
    off = _run(tmp_path / "off", 240)
    zero = _run(tmp_path / "zero", 240, "ppo.explore_eps=0.0", "ppo.explore_decay=100")
    on = _run(tmp_path / "on", 240, *EXPLORE["samples"])
    assert zero == off and all(r["epsilon"] == "0.0" for r in off)
    assert [r["episode_return"] for r in on] != [r["episode_return"] for r in off]


def test_a_config_written_before_exploration_loads_with_it_off(tmp_path):
    """A saved schema-2 config (no ``explore_*`` keys) of the task whose training defaults
    explore reads every exploration setting as off, so it resumes as it trained; a file without
    a schema (written by hand) takes the task's defaults for what it leaves unset."""
    saved = TrainConfig(task="box_pushing_grid").to_dict()
    for key in [k for k in saved["ppo"] if k.startswith("explore_")]:
        del saved["ppo"][key]
    path = tmp_path / "config.json"
    path.write_text(json.dumps({SCHEMA_KEY: 2, **saved}))
    learner = TrainConfig.load(path).resolved().learner
    assert (learner.explore_eps, learner.explore_eps_end, learner.explore_decay) == (0, 0, 0)
    assert (learner.explore_unit, learner.explore_form) == ("samples", "agent")
    assert learner.exploration(10**6, 10**6) == 0.0
    handmade = tmp_path / "run.yaml"
    handmade.write_text("task: box_pushing_grid\nppo:\n  epochs: 4\n")
    learner = TrainConfig.load(handmade).resolved().learner
    assert (learner.epochs, learner.explore_eps, learner.explore_form) == (4, 1.0, "joint")


def test_the_command_line_takes_the_tasks_exploration_unless_told_otherwise():
    def learner(*argv: str):
        return parse_args(["--task", "box_pushing_grid", *argv])[0].resolved().learner

    assert (learner().explore_eps, learner().explore_form) == (1.0, "joint")
    assert (learner("ppo.lr=0.001").lr, learner("ppo.lr=0.001").explore_eps) == (0.001, 1.0)
    assert learner("ppo.explore_eps=0").explore_eps == 0.0
    assert learner("--method", "async-rnn").explore_unit == "episodes"
    assert not hasattr(learner("--method", "mac-dqn"), "explore_eps")


def test_a_task_turns_exploration_on_for_every_ppo_method_unless_told_otherwise(monkeypatch):
    """``register_task(train_defaults={"ppo.explore_eps": ...})``: every method with a ``ppo``
    section takes it, a method's own settings and the user's win, Mac-DQN is left alone."""
    from maopg.tasks import registry
    from maopg.tasks.box_pushing_grid.task import BoxPushingGrid

    monkeypatch.setattr(registry, "_TASKS", dict(registry._TASKS))
    defaults = {"ppo.explore_eps": 0.5, "ppo.explore_decay": 1000, "total_samples": 5000}
    registry.register_task("exploring_grid", BoxPushingGrid, train_defaults=defaults)

    def learner(**given):
        return TrainConfig.from_dict({"task": "exploring_grid", **given}).resolved().learner

    assert (learner().explore_eps, learner().explore_decay) == (0.5, 1000)
    assert learner(method="async-rnn", ppo={"epochs": 3}).explore_eps == 0.5
    assert learner(ppo={"explore_eps": 0.1}).explore_eps == 0.1
    assert not hasattr(learner(method="mac-dqn"), "explore_eps")
    assert TrainConfig(task="exploring_grid").resolved().learner.explore_eps == 0.5


def test_box_pushing_grid_explores_by_default_and_tool_delivery_does_not():
    """The grid's training defaults (the pilots' best setting); the paper's tasks unchanged."""
    grid = TrainConfig(task="box_pushing_grid").resolved().learner
    assert (grid.explore_eps, grid.explore_form, grid.explore_unit) == (1.0, "joint", "episodes")
    assert TrainConfig(task="tool_delivery").resolved().learner.explore_eps == 0.0
