"""Whole episodes collected in rounds, as the macro-action actor-critic literature trains
(ACAC, Mac-IAICC and its siblings: MacroMARL's runner): every environment restarts at each
round, all step in lockstep until enough episodes have finished, the last of them are the
batch, and the unfinished are dropped. Learners that train this way share it
(:mod:`maopg.learner.acac`, :mod:`maopg.learner.mac_iaicc`)."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from maopg.env.contract import DecisionPoint
from maopg.env.vector import SeededVectorEnv
from maopg.policy import ObsBatch, OptionPolicy, episode_starts, stack_conditions
from maopg.policy.conditional import FactoredConditional, mix_uniform


@dataclass
class Episodes:
    """A round's training batch: ``B`` finished episodes as ``[T, B]`` grids over their decision
    points, row ``J_b`` of episode ``b`` its final point (padding after it: ``valid`` false)."""

    obs: ObsBatch
    """``T * B`` rows, time-major."""
    choosing: Tensor
    """``bool [T, B, N]``."""
    running: Tensor
    available: Tensor
    joint: Tensor
    """``int64 [T, B, N]``: the joint option taken at each decision point."""
    reward: np.ndarray
    """``[T, B]``: the discounted reward of the step from each point."""
    reward_sum: np.ndarray
    """``[T, B]``: its summed reward."""
    duration: np.ndarray
    terminated: np.ndarray
    """``bool [B]``: the episode ended in a terminal state (else a timeout)."""
    length: np.ndarray
    """``int [B]``: decision points ``J_b`` before the final point."""

    @property
    def steps(self) -> Tensor:
        """``bool [T, B]``: rows that are a step (a decision point that was acted on)."""
        t = torch.arange(self.choosing.shape[0]).unsqueeze(1)
        return t < torch.from_numpy(self.length).unsqueeze(0)

    @property
    def starts(self) -> Tensor:
        starts = torch.zeros(self.choosing.shape[:2], dtype=torch.bool)
        starts[0] = True
        return starts


def stack_episodes(rows: list[list[tuple[DecisionPoint, np.ndarray]]], finals: list) -> Episodes:
    """Stack episodes given as ``(point, joint)`` rows plus each one's final point."""
    longest = max(len(r) for r in rows) + 1
    n = len(finals[0].choosing)
    points, joints = [], []
    filler = finals[0]
    for episode, final in zip(rows, finals, strict=True):
        seq = [p for p, _ in episode] + [final]
        points.append(seq + [filler] * (longest - len(seq)))
        joints.append([j for _, j in episode] + [np.zeros(n, np.int64)] * (longest - len(episode)))
    by_time = [points[b][t] for t in range(longest) for b in range(len(rows))]
    obs = ObsBatch.from_decision_points(by_time)
    choosing, running, available = (
        c.view(longest, len(rows), -1) for c in stack_conditions(by_time)
    )
    reward = np.zeros((longest, len(rows)))
    reward_sum = np.zeros((longest, len(rows)))
    duration = np.ones((longest, len(rows)))
    for b, seq in enumerate(points):
        for t, point in enumerate(seq[1 : len(rows[b]) + 1]):
            reward[t, b] = point.discounted_reward
            reward_sum[t, b] = point.reward
            duration[t, b] = point.duration
    joint = torch.from_numpy(np.stack([np.stack(j) for j in joints], axis=1))
    terminated = np.array([f.terminated for f in finals])
    length = np.array([len(r) for r in rows])
    return Episodes(
        obs, choosing, running, available, joint, reward, reward_sum, duration, terminated, length
    )


def collect_round(
    envs: SeededVectorEnv,
    policy: OptionPolicy,
    epsilon: float,
    wanted: int,
    generator: torch.Generator,
    device: torch.device,
) -> tuple[Episodes, list[dict[str, Any]], int]:
    """One round: every environment starts a new episode and all step in lockstep, ``policy``'s
    choosing agents drawing from ``(1 − ε) π_i + ε / |A_i|`` (:func:`mix_agents`), until the tick
    by which ``wanted`` episodes have finished; returns the last ``wanted`` to finish as the
    batch, the info of every episode that finished in the round, the ticks simulated.

    The literature's environments advance a tick at a time and a round stops at the first tick
    by which ``wanted`` episodes have finished; these advance a decision point at a time, each
    by its own option's ticks. So every finish is kept with the round tick it came at, the
    environments step until none can still finish at or before the tick of the ``wanted``-th
    earliest finish (every one has passed it), and the round is what theirs would have been:
    the episodes finished by then, ordered by tick (then environment), the last ``wanted`` of
    them the batch. The ticks simulated past that tick are in the count all the same."""
    envs.restart()
    state = policy.initial_state(envs.num_envs)
    state = None if state is None else state.to(device)
    open_rows: list[list[tuple[DecisionPoint, np.ndarray]]] = [[] for _ in envs.points]
    finishes: list[tuple[int, int, list, DecisionPoint]] = []
    """(round tick, environment, rows, final point) of every finished episode."""
    elapsed = np.zeros(envs.num_envs, dtype=np.int64)
    cutoff = math.inf
    while elapsed.min() < cutoff:
        points = envs.points
        obs = ObsBatch.from_decision_points(points).to(device)
        conditions = [c.to(device) for c in stack_conditions(points)]
        starts = episode_starts(points).to(device)
        dist, state = policy.step(obs, *conditions, state, starts)
        if epsilon:
            dist = mix_agents(dist, epsilon)  # type: ignore[arg-type]
        joint = dist.sample(generator).cpu().numpy()
        kept = [copy.deepcopy(p) for p in points]
        results = envs.step(joint)
        for e, result in enumerate(results):
            open_rows[e].append((kept[e], joint[e]))
            elapsed[e] += result.outcome.duration
            if result.final is not None:
                final = copy.deepcopy(result.final)
                finishes.append((int(elapsed[e]), e, open_rows[e], final))
                open_rows[e] = []
        if len(finishes) >= wanted:
            cutoff = sorted(f[0] for f in finishes)[wanted - 1]
    done = sorted((f for f in finishes if f[0] <= cutoff), key=lambda f: (f[0], f[1]))
    batch = stack_episodes([f[2] for f in done[-wanted:]], [f[3] for f in done[-wanted:]])
    infos = [dict(f[3].info["episode"]) for f in done]
    return batch, infos, int(elapsed.sum())


def mix_agents(dist: FactoredConditional, epsilon: float) -> FactoredConditional:
    """``dist`` with each choosing agent's factor mixed with the uniform over its available
    options, ``(1 − ε) π_i + ε / |A_i|``."""
    eps = torch.full((len(dist.choosing),), epsilon, device=dist.choosing.device)
    mixed = [
        torch.where(dist.choosing[:, i : i + 1], mix_uniform(lp, eps), lp)
        for i, lp in enumerate(dist.agent_log_probs)
    ]
    return FactoredConditional(mixed, dist.choosing, dist.running)
