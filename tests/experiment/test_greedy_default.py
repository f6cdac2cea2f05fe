"""How a trained policy acts unless told otherwise: one default
(:data:`maopg.experiment.evaluation.GREEDY_BY_DEFAULT`) for ``load_policy``, ``python -m eval
evaluate`` and ``python -m eval video``, and both ways by a flag."""

from __future__ import annotations

import inspect

import pytest

from maopg.experiment import load_policy
from maopg.experiment.cli.eval_cli import build_parser
from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.evaluation import GREEDY_BY_DEFAULT
from maopg.experiment.evaluation.loading import Trained


@pytest.mark.parametrize(
    ("flags", "sample"),
    [([], not GREEDY_BY_DEFAULT), (["--greedy"], False), (["--sample"], True)],
)
@pytest.mark.parametrize("command", ["evaluate", "video"])
def test_greedy_and_sample_choose_how_a_checkpoint_acts(command, flags, sample):
    args = [command, "--checkpoint", "run", *flags] + (["--out", "v.mp4"] * (command == "video"))
    assert build_parser().parse_args(args).sample is sample


def test_greedy_and_sample_exclude_each_other(user_error):
    user_error(
        eval_main,
        ["evaluate", "--checkpoint", "run", "--greedy", "--sample"],
        r"--sample: not allowed with argument --greedy",
    )


def test_load_policy_and_a_trained_actor_take_the_same_default():
    for function in (load_policy, Trained.actor, Trained.label):
        assert inspect.signature(function).parameters["greedy"].default is GREEDY_BY_DEFAULT


def test_the_help_names_the_default_and_where_it_is_said(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["video", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "default --greedy, maopg.experiment.evaluation.GREEDY_BY_DEFAULT says why" in text
