"""Trained policies for evaluation: load a checkpoint, rebuild its environment and network.

A checkpoint (``final.pt`` or ``checkpoint.pt`` from ``python -m train``) stores the resolved
training config and the acting network's weights, and the config names the method, whose
registry entry (:mod:`maopg.experiment.run.methods`) says how to rebuild that network and how it
acts — so nothing needs to be given twice, and a user's method loads like a built-in one.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from torch import nn

from maopg.env import EnvSpec, OptionEnv
from maopg.experiment.evaluation import GREEDY_BY_DEFAULT
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import CHECKPOINT, FINAL
from maopg.experiment.run.methods import Method, get_method
from maopg.experiment.run.migration import read_checkpoint
from maopg.learner import Actor, CheckpointError, fitting
from maopg.plugins import load_plugins
from maopg.policy import set_precision

CHECKPOINT_NAMES = (FINAL, CHECKPOINT)
"""Looked for, in this order, when a run directory is given instead of a file."""


@dataclass
class Trained:
    """A checkpoint's config and acting network."""

    path: Path
    config: TrainConfig
    method: Method
    policy: nn.Module
    samples: int
    spec: EnvSpec
    """The spec of the environment it was trained on (agents, options, observation sizes)."""

    def make_env(self, seed: int = 0, overrides: Mapping[str, Any] | None = None) -> OptionEnv:
        """The environment the policy was trained on (task, strategy, observations), with the
        task settings ``overrides`` over the run's own (``{"appearance": "heldout"}``: the same
        task seen in looks it never trained on). Settings that change what the policy reads or
        chooses from (its agents, their options, their observations) are refused, naming them:
        its network could not act there."""
        config = self.config.env()
        if overrides:
            config = dataclasses.replace(config, overrides={**config.overrides, **overrides})
        env = config.make(seed)
        if overrides and _acting_shape(env.spec) != _acting_shape(self.spec):
            env.close()
            given = ", ".join(f"env.{key}={value}" for key, value in overrides.items())
            raise ValueError(
                f"{given}: the checkpoint's policy cannot act there (its agents, their options "
                "or their observations change); a checkpoint takes task settings that keep "
                "them, such as env.appearance or env.max_ticks"
            )
        return env

    def actor(self, *, greedy: bool = GREEDY_BY_DEFAULT, seed: int = 0) -> Actor:
        """The trained policy as ``DecisionPoint -> joint option``: the mode (greedy, the
        default: :data:`~maopg.experiment.evaluation.GREEDY_BY_DEFAULT`) or a sample seeded with
        ``seed`` — for Mac-DQN, ε-greedy at its final exploration rate."""
        return self.method.learner_class.actor(
            self.policy, self.config.learner, greedy=greedy, seed=seed
        )

    def label(self, *, greedy: bool = GREEDY_BY_DEFAULT) -> str:
        """Who acts, for a video's title: the method, its training seed and how it acts
        (``async seed 2 (sampled)``, ``mac-dqn seed 0 (ε-greedy)``)."""
        mode = "greedy" if greedy else self.method.learner_class.sampled_name
        return f"{self.config.method} seed {self.config.seed} ({mode})"


def _acting_shape(spec: EnvSpec) -> tuple[object, ...]:
    """What of an environment a policy's network is built for: each agent's options and
    observation layout, the images' shape, their channels (``rgb+depth`` and ``rgb+seg``
    share a shape, not an encoder) and the segmentation classes the encoder's one-hot
    reads."""
    agents = tuple((a.name, a.option_names, a.layout) for a in spec.agents)
    channels = spec.image_channels
    return agents, spec.image_shape, channels.names, len(channels.classes)


def resolve_checkpoint(path: str | Path) -> Path:
    """``path`` itself if it is a file, else the first of :data:`CHECKPOINT_NAMES` in it."""
    path = Path(path)
    if path.is_file():
        return path
    for name in CHECKPOINT_NAMES:
        if (path / name).is_file():
            return path / name
    raise FileNotFoundError(f"{path} is neither a checkpoint file nor a run directory with one")


def load_trained(path: str | Path, device: str = "cpu") -> Trained:
    """Rebuild the policy of a checkpoint (file or run directory) with its weights, on
    ``device`` (``cpu``, ``cuda`` or ``auto``, as the training setting).

    The default is ``cpu`` whatever the run trained on: a trained policy acts on one decision
    point at a time, where a GPU only adds a transfer per step, and on the CPU an evaluation is
    bit-reproducible. The checkpoint's tensors are CPU tensors (:mod:`maopg.learner.checkpoint`),
    so a policy trained on a GPU loads on a machine without one. ``config.device`` of the
    result is the device it was loaded on.
    """
    file = resolve_checkpoint(path)
    state = read_checkpoint(file, required=("config",))
    load_plugins(state["config"].get("plugins", []))  # the run's task or method may be theirs
    saved = TrainConfig.from_dict(state["config"])
    config = dataclasses.replace(saved, device=device).resolved()
    method = get_method(config.method)
    env = config.env().make(0)
    try:
        spec = env.spec
    finally:
        env.close()
    policy = method.build_policy(
        spec, hidden=config.hidden, layers=config.layers, config=config.learner
    )
    key = method.learner_class.policy_key
    if key not in state:
        raise CheckpointError(f"checkpoint {file} lacks the entries [{key!r}]")
    with fitting(file):
        policy.load_state_dict(state[key])
    policy.to(config.device)
    set_precision(policy, config.precision)  # act as it learnt to
    return Trained(file, config, method, policy, int(state.get("samples", 0)), spec)
