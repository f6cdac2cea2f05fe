"""Fixtures of the learner tests."""

from __future__ import annotations

import threading
from collections.abc import Callable

import pytest
import torch

from maopg.env.vector import SeededVectorEnv
from maopg.learner import MAPPO, LearnerSetup, TrainBatch


@pytest.fixture
def update_both_ways() -> Callable[[Callable[[], MAPPO], TrainBatch], tuple[dict, dict]]:
    """``update_both_ways(make, batch)``: one PPO update of ``batch`` by a fresh ``make()`` as
    the learner runs it (the critic's steps on its own thread, checked by forward hooks), and
    one with every step on this thread, critic first; returns each one's statistics and final
    parameters, keyed ``"threads"`` and ``"inline"``."""

    def run(make: Callable[[], MAPPO], batch: TrainBatch) -> tuple[dict, dict]:
        results = {}
        for name in ("threads", "inline"):
            learner = make()
            learner.overlap_critic = name == "threads"
            threads: set[str] = set()
            for module in learner.critic.modules():  # forward or a recurrent sequence
                module.register_forward_hook(
                    lambda *_, seen=threads: seen.add(threading.current_thread().name)
                )
            stats = learner.update(batch, torch.Generator().manual_seed(1))
            on_own_thread = all(t.startswith("maopg-critic") for t in threads)
            assert threads and on_own_thread == (name == "threads"), threads
            networks = (learner.policy, learner.critic)
            weights = {
                f"{i}.{k}": v for i, n in enumerate(networks) for k, v in n.state_dict().items()
            }
            results[name] = {"stats": stats, "weights": weights}
        return results["threads"], results["inline"]

    return run


@pytest.fixture
def setup_for() -> Callable[[SeededVectorEnv, object], LearnerSetup]:
    """``setup_for(envs, config)``: what the round learners' tests (ACAC, Mac-IAICC) build a
    learner on: ``envs``' team, small networks, γ 0.98, seeded sampling."""

    def make(envs: SeededVectorEnv, config: object) -> LearnerSetup:
        return LearnerSetup(
            spec=envs.spec,
            config=config,
            num_envs=envs.num_envs,
            batch_ticks=1,
            gamma=0.98,
            hidden=32,
            layers=2,
            sample_gen=torch.Generator().manual_seed(1),
            update_gen=torch.Generator(),
        )

    return make
