"""What the trainer watches of every environment step: ticks for its progress bar and the
options chosen, for TensorBoard. Learners know nothing of either; the trainer hangs this on the
vector environment's step hook (:attr:`maopg.env.vector.SeededVectorEnv.on_step`).

A Water Filling batch is 2,000 ticks (45 s from images): a bar that moved only between batches
sat at 0% that long. The choice frequencies show a policy collapsing onto one option (Water
Filling's greedy vehicle picks ``Fill(0)`` 99% of the time) while it happens, which the return
alone does not.

It also times the collection and keeps the lengths of the episodes that end, for the whole
run's ETA (:mod:`maopg.experiment.training.eta`): what the evaluation after training will cost.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.env.vector_base import StepResult
from maopg.progress import Progress


class StepWatch:
    """Advances ``bar`` by each step's ticks, counts each agent's chosen options, and times the
    collection (:meth:`start` marks where it begins)."""

    def __init__(self, spec: EnvSpec, bar: Progress) -> None:
        self.spec = spec
        self.bar = bar
        self.counts = [np.zeros(a.num_options, np.int64) for a in spec.agents]
        self.collecting_s = 0.0
        """Seconds from each :meth:`start` or step to the end of the next step: acting and
        stepping, not the learning between batches (a learner that learns between steps, as
        Mac-DQN does, has it counted: the estimate errs long)."""
        self.ticks = 0
        """Ticks of all environments in ``collecting_s``."""
        self.episodes = 0
        self.episode_ticks = 0
        """Episodes that ended, and their ticks in all."""
        self._since: float | None = None

    def start(self) -> None:
        """A collection starts now (the trainer calls it at each iteration's start)."""
        self._since = time.perf_counter()

    @property
    def episode_length(self) -> float | None:
        """Mean length of the episodes that ended, ``None`` while none did."""
        return self.episode_ticks / self.episodes if self.episodes else None

    def __call__(
        self, points: Sequence[DecisionPoint], joints: np.ndarray, results: Sequence[StepResult]
    ) -> None:
        now = time.perf_counter()
        ticks = sum(r.outcome.duration for r in results)
        if self._since is not None:
            self.collecting_s += now - self._since
            self.ticks += ticks
        self._since = now
        for result in results:
            if result.final is not None:
                self.episodes += 1
                self.episode_ticks += result.final.info["episode"]["ticks"]
        self.bar.update(max(0, min(ticks, self.bar.total - self.bar.n)))
        for point, joint in zip(points, joints, strict=True):
            for i in np.flatnonzero(point.choosing):
                self.counts[i][joint[i]] += 1

    def take_frequencies(self) -> dict[str, float]:
        """``agent/option`` → its share of the agent's choices since the last call (agents that
        made no choice are left out); the counts start again."""
        shares = {}
        for agent, counts in zip(self.spec.agents, self.counts, strict=True):
            total = int(counts.sum())
            if total:
                for name, count in zip(agent.option_names, counts, strict=True):
                    shares[f"{agent.name}/{name}"] = float(count) / total
            counts[:] = 0
        return shares
