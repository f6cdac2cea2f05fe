"""The command lines are a public interface: today's commands, flags, ``key=value`` spellings
and console scripts keep working whatever the package's layout. A flag may be added; one listed
here may not disappear or change its meaning without a deprecation."""

from __future__ import annotations

import argparse
import importlib
import tomllib
from pathlib import Path

import pytest

from maopg.experiment.cli import eval_cli, train_cli

ROOT = Path(__file__).resolve().parents[2]

TRAIN_FLAGS = {
    "--task",
    "--method",
    "--seed",
    "--run-dir",
    "--total-samples",
    "--resume",
    "--overwrite",
    "--images",
    "--no-images",
    "--import",
    "--config",
    "--debug",
}
EVAL_FLAGS = {
    "evaluate": {"--checkpoint", "--reference", "--task", "--strategy", "--seed", "--sample"}
    | {"--device", "--episodes", "--json", "--no-progress"},
    "video": {"--checkpoint", "--reference", "--task", "--strategy", "--seed", "--sample"}
    | {"--device", "--out", "--fps", "--no-progress"},
    "plot": {"--methods", "--metric", "--out", "--reference-episodes", "--unfinished"}
    | {"--window", "--no-progress"},
    "table": {"--methods", "--out", "--threshold", "--unfinished", "--window"},
    "check-robot": {"--robot", "--role", "--timestep"},
    "reproduce": {"--study", "--no-train", "--list-studies", "--runs", "--results", "--tasks"}
    | {"--methods", "--seeds", "--config", "--threshold", "--window", "--eval-episodes"}
    | {"--reference-episodes", "--in-process", "--jobs", "--dry-run"},
}
SCRIPTS = ("maopg-train", "maopg-eval")
"""The console scripts (their targets are checked to resolve, wherever they live)."""


def _flags(parser: argparse.ArgumentParser) -> set[str]:
    return {flag for flag in parser._option_string_actions if flag.startswith("--")}


def test_train_keeps_its_flags():
    assert _flags(train_cli.build_parser()) >= TRAIN_FLAGS


@pytest.mark.parametrize("command", sorted(EVAL_FLAGS))
def test_eval_keeps_its_commands_and_flags(command):
    parser = eval_cli.build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    assert command in sub.choices
    assert EVAL_FLAGS[command] <= _flags(sub.choices[command])


def test_key_value_spellings_still_parse():
    config, _ = train_cli.parse_args(
        [
            "--task",
            "tool_delivery",
            "--method",
            "async",
            "video=false",
            "plot=false",
            "env.max_ticks=40",
            "ppo.epochs=3",
            "seed=0",
            "num_envs=2",
        ]
    )
    assert (config.video, config.plot, config.env_overrides) == (False, False, {"max_ticks": 40})
    assert config.learner.epochs == 3 and config.num_envs == 2
    dqn, _ = train_cli.parse_args(["--method", "mac-dqn", "dqn.lr=1e-3"])
    assert dqn.learner.lr == 1e-3


def test_the_console_scripts_keep_their_names_and_resolve():
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert set(SCRIPTS) <= set(scripts)
    for name, target in scripts.items():
        module, _, attr = target.partition(":")
        assert callable(getattr(importlib.import_module(module), attr)), name
    for folder in ("train", "eval"):  # `python -m train` / `python -m eval` from a clone
        assert "main()" in (ROOT / folder / "__main__.py").read_text()
