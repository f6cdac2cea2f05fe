"""Tasks declare the termination strategies they run under (issue #43): a method or strategy
a task does not support is one line before anything is written, for the built-in tasks and
for a user's, whose strategies the base class derives from what it implements."""

from __future__ import annotations

import pytest

from examples.berries import BerryConfig, BerryField
from maopg.env import Strategy, make_env
from maopg.env.pettingzoo import parallel_env
from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main as train_main
from maopg.tasks import Task, registry, task_class, task_names
from maopg.tasks.base import require_strategy

QUICK = ["--total-samples", "60", "batch_ticks=60", "num_envs=1", "backend=local"]
QUICK += ["progress=false", "video=false", "plot=false", "eval_episodes=0"]


class Standstill(BerryField):
    """A user's task without ``hold()``: its agents can neither idle (sync-wait) nor be
    interrupted (sync-cut: :meth:`maopg.options.base.Option.interrupt` holds)."""

    hold = Task.hold


class Declared(Standstill):
    """A task that declares its strategies: they stand, here and in its subclasses."""

    strategies = frozenset({Strategy.CONTINUE, Strategy.ANY})


class Inherits(Declared):
    def hold(self, agent: int) -> None:
        """A hold of its own does not add ``all`` to what its parent declared."""


@pytest.fixture
def standstill(monkeypatch) -> str:
    """``standstill`` registered for one test (the registry is restored after)."""
    monkeypatch.setattr(registry, "_TASKS", dict(registry._TASKS))
    registry.register_task("standstill", Standstill, config=BerryConfig)
    return "standstill"


@pytest.mark.parametrize("task", task_names())
def test_every_registered_task_declares_what_it_supports(task):
    supported = task_class(task).supported_strategies()
    assert Strategy.CONTINUE in supported and supported <= frozenset(Strategy)
    if task in ("tool_delivery", "water_filling"):
        assert supported == frozenset(Strategy)


def test_the_strategies_follow_what_a_task_implements_unless_it_declares_them():
    assert BerryField.supported_strategies() == frozenset(Strategy)
    assert Standstill.supported_strategies() == {"continue", "primitive"}
    assert Declared.supported_strategies() == Inherits.supported_strategies() == {"continue", "any"}
    with pytest.raises(ValueError, match=r"^task 'x' does not support strategy 'all'; it "):
        require_strategy(Inherits, "x", "all")


def test_sync_wait_on_a_task_without_hold_is_one_line_before_anything_is_written(
    tmp_path, standstill, user_error
):
    run = tmp_path / "run"
    args = ["--task", standstill, *QUICK, "--run-dir", str(run)]
    expected = (
        r"^python -m train: error: task 'standstill' does not support method 'sync-wait' "
        r"\(strategy 'all'\); it supports: continue, primitive\n$"
    )
    user_error(train_main, [*args, "--method", "sync-wait"], expected)
    assert not run.exists()
    user_error(train_main, [*args, "--method", "sync-cut"], r"'sync-cut' \(strategy 'any'\)")
    assert not run.exists()
    assert train_main([*args, "--method", "async"]) == 0  # continue runs


def test_an_evaluation_under_an_unsupported_strategy_is_one_line(standstill, user_error):
    argv = ["evaluate", "--reference", "random", "--task", standstill, "--strategy", "all"]
    user_error(eval_main, argv, r"task 'standstill' does not support strategy 'all'")


@pytest.mark.parametrize("build", [make_env, parallel_env])
def test_the_environment_apis_refuse_an_unsupported_strategy(standstill, build):
    """Building the environment (:func:`maopg.env.make_env`, the PettingZoo view) under a
    strategy the task does not run refuses it there, not at its first idle tick."""
    with pytest.raises(ValueError, match=r"^task 'standstill' does not support strategy 'all'"):
        build(standstill, "all")
    build(standstill, "continue").close()
