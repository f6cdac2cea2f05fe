"""Acting with a trained policy from Python, in three lines::

    policy = load_policy("runs/tool_delivery/async/seed0")
    joint = policy.act(point)                       # a DecisionPoint -> the joint option
    actions = policy.act_dict(observations, infos)  # the PettingZoo view's dicts -> {agent: option}

:class:`Policy` wraps the checkpoint's actor (:meth:`Trained.actor`), so both calls give the
actions evaluation and videos take. The PettingZoo path rebuilds the decision point from the
view's observations and infos (:func:`maopg.env.pettingzoo.decision_point`: the running options
and who chooses are in the infos), so a recurrent policy, whose memory restarts where
``ticks == 0``, works there too. Either way one :class:`Policy` plays one episode at a time,
its points in order, as the actor does.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from maopg.env import DecisionPoint, OptionEnv
from maopg.env.pettingzoo import OptionParallelEnv, decision_point
from maopg.experiment.evaluation import GREEDY_BY_DEFAULT
from maopg.experiment.evaluation.loading import Trained, load_trained
from maopg.learner import Actor


@dataclass
class Policy:
    """A trained policy acting on decision points and on the PettingZoo view."""

    trained: Trained
    actor: Actor

    @property
    def agents(self) -> tuple[str, ...]:
        """The agents it acts for, in the order of a joint option."""
        return self.trained.spec.agent_names

    def act(self, point: DecisionPoint) -> np.ndarray:
        """The joint option at ``point`` (``int64 [N]``; continuing agents keep theirs)."""
        return np.asarray(self.actor(point), dtype=np.int64)

    def act_dict(
        self,
        observations: Mapping[str, Mapping[str, np.ndarray]],
        infos: Mapping[str, Mapping[str, Any]],
    ) -> dict[str, int]:
        """``{agent: option}`` for every agent of :meth:`OptionParallelEnv.reset` / ``step``'s
        ``observations`` and ``infos`` — a continuing agent's entry is its running option, which
        the view accepts; keep only ``infos[agent]["choosing"]`` ones for an RLlib-style
        consumer."""
        joint = self.act(decision_point(self.agents, observations, infos))
        return {agent: int(option) for agent, option in zip(self.agents, joint, strict=True)}

    def make_env(self, seed: int = 0) -> OptionEnv:
        """The environment it was trained on."""
        return self.trained.make_env(seed)

    def parallel_env(self, seed: int = 0, render_mode: str | None = None) -> OptionParallelEnv:
        """The PettingZoo view of the environment it was trained on."""
        return OptionParallelEnv(self.make_env(seed), render_mode=render_mode)


def load_policy(
    path: str | Path, *, greedy: bool = GREEDY_BY_DEFAULT, seed: int = 0, device: str = "cpu"
) -> Policy:
    """The policy of a checkpoint (a file or a run directory, :func:`load_trained`): its mode
    (``greedy``, the default: :data:`~maopg.experiment.evaluation.GREEDY_BY_DEFAULT`) or sampled
    with ``seed``, on ``device``."""
    trained = load_trained(path, device=device)
    return Policy(trained, trained.actor(greedy=greedy, seed=seed))
