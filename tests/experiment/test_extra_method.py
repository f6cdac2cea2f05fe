"""A method added from outside the package — one learner class and one registry line, here in the
test file — trains, resumes and evaluates through the command lines like a built-in one.

The method is REINFORCE over options: the paper's conditional centralized policy, trained on
Monte-Carlo returns of whole option-level episodes (no critic), with its own config section.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import pytest
import torch

from maopg.env.vector import SeededVectorEnv
from maopg.experiment import Method, register_method
from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.run import methods
from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.learner import Learner, LearnerSetup, PPOConfig
from maopg.learner.base import episode_metrics
from maopg.learner.checkpoint import load_checkpoint
from maopg.learner.mappo import centralized_policy
from maopg.policy import DistributionActor, ObsBatch, OptionPolicy, stack_conditions


@dataclass(frozen=True)
class ReinforceConfig:
    lr: float = 1e-3

    def validate(self) -> None:
        if self.lr <= 0:
            raise ValueError(f"reinforce.lr must be > 0, got {self.lr}")


class ReinforceLearner(Learner):
    """Collect whole episodes, then one gradient step on ``-Σ log π̂(o^U | c, z) · G_t``."""

    Config = ReinforceConfig
    section = "reinforce"
    columns: ClassVar[tuple[str, ...]] = ("loss",)
    policy_key = "policy"

    def __init__(self, policy: OptionPolicy, setup: LearnerSetup) -> None:
        super().__init__(policy, setup)
        self.optimizer = torch.optim.Adam(policy.parameters(), lr=self.config.lr)

    def iteration(self, envs: SeededVectorEnv, samples: int) -> tuple[dict[str, Any], int]:
        steps: list[tuple[torch.Tensor, list[float], list[int]]] = []
        episodes: list[dict[str, Any]] = []
        rewards, ticks = [], 0
        while ticks < self.setup.batch_ticks:
            points = envs.points
            dist = self.policy.distribution(
                ObsBatch.from_decision_points(points), *stack_conditions(points)
            )
            joint = dist.sample(self.setup.sample_gen)
            results = envs.step(joint.numpy())
            outcomes = [r.outcome for r in results]
            steps.append(
                (dist.log_prob(joint), [o.reward for o in outcomes], [o.done for o in outcomes])
            )
            episodes += [dict(r.final.info["episode"]) for r in results if r.final is not None]
            rewards += [o.reward for o in outcomes]
            ticks += sum(o.duration for o in outcomes)
        returns = torch.zeros(envs.num_envs)
        loss = torch.zeros(())
        for log_prob, reward, done in reversed(steps):  # undiscounted returns to episode end
            returns = torch.tensor(reward) + returns * (1.0 - torch.tensor(done, dtype=torch.float))
            loss = loss - (log_prob * returns).mean()
        self.optimizer.zero_grad()
        (loss / len(steps)).backward()
        self.optimizer.step()
        row = {
            "option_steps": len(rewards),
            **episode_metrics(episodes),
            "option_step_reward": sum(rewards) / len(rewards),
            "loss": float(loss.detach()) / len(steps),
        }
        return row, ticks

    def state_dict(self) -> dict[str, Any]:
        return {"policy": self.policy.state_dict(), "optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.policy.load_state_dict(state["policy"])
        self.optimizer.load_state_dict(state["optimizer"])

    @staticmethod
    def actor(policy: OptionPolicy, config: ReinforceConfig, *, greedy: bool, seed: int):
        return DistributionActor(policy, greedy=greedy, seed=seed)


@pytest.fixture
def reinforce(monkeypatch):
    monkeypatch.setattr(methods, "_METHODS", dict(methods._METHODS))
    return register_method(Method("reinforce", "continue", ReinforceLearner, centralized_policy))


def _rows(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as handle:
        return [
            {k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in csv.DictReader(handle)
        ]


ARGS = ["--method", "reinforce", "--seed", "1", "batch_ticks=100", "num_envs=2", "env.max_ticks=50"]
QUIET = [
    "progress=false",
    "video=false",
    "eval_episodes=0",
    "plot=false",
    "checkpoint_every=1",
    "reinforce.lr=3e-3",
]


def test_a_registered_method_trains_resumes_and_evaluates_through_the_cli(
    reinforce, tmp_path, capsys, user_error
):
    whole, split = tmp_path / "whole", tmp_path / "split"
    train_main([*ARGS, *QUIET, "--total-samples", "400", "--run-dir", str(whole)])
    rows = _rows(whole)
    assert list(rows[0]) == [c for c in reinforce.columns if c not in TIMING_COLUMNS]
    assert int(rows[-1]["samples"]) >= 400 and all(r["loss"] != "nan" for r in rows)
    final = load_checkpoint(whole / "final.pt")
    assert final["config"]["reinforce"] == {"lr": 3e-3} and "ppo" not in final["config"]

    # half the budget, then --resume with the whole budget: the same curve, bit for bit
    train_main([*ARGS, *QUIET, "--total-samples", "200", "--run-dir", str(split)])
    train_main(["--resume", "--run-dir", str(split), "--total-samples", "400", "progress=false"])
    assert _rows(split) == rows

    assert eval_main(["evaluate", "--checkpoint", str(split), "--episodes", "2", "--sample"]) == 0
    assert "| reinforce seed1 @" in capsys.readouterr().out

    bad = [*ARGS, "reinforce.lr=-1", "--run-dir", str(tmp_path / "bad")]
    user_error(train_main, bad, r"reinforce\.lr must be > 0")  # checked like ppo.*


def test_a_builder_without_the_target_keyword_is_refused_at_registration(monkeypatch):
    """Builders are called with ``target`` (what they build for); one written for the earlier
    signature fails in one line when it registers, not with a TypeError mid-run."""
    monkeypatch.setattr(methods, "_METHODS", dict(methods._METHODS))

    def earlier(spec: Any, *, hidden: int, layers: int, config: Any) -> torch.nn.Module:
        return centralized_policy(spec, hidden=hidden, layers=layers, config=config)

    with pytest.raises(ValueError, match=r"lacks the keyword\(s\) \['target'\]"):
        register_method(Method("earlier", "continue", ReinforceLearner, earlier))
    assert "earlier" not in methods.method_names()


def test_a_learner_named_by_a_string_brings_its_section(monkeypatch):
    """The registry reads a lazily named learner's section from its ``config`` (no import);
    the class, once imported, must be the one that section belongs to."""
    monkeypatch.setattr(methods, "_METHODS", dict(methods._METHODS))
    learner = f"{__name__}:ReinforceLearner"
    with pytest.raises(ValueError, match=r"needs config=, its Config, whose PREFIX names"):
        register_method(Method("lazy", "continue", learner, f"{__name__}:centralized_policy"))
    method = register_method(
        Method(
            "lazy", "continue", learner, "maopg.learner.mappo:centralized_policy", config=PPOConfig
        )
    )
    assert method.section == "ppo"
    with pytest.raises(TypeError, match=r"has section 'reinforce'.*not 'ppo'"):
        assert method.learner_class
