"""Fixtures of the learner tests."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from typing import Any

import pytest
import torch

import maopg.learner.mappo as mappo
from maopg.learner import MAPPO, TrainBatch


class _Inline:
    """An executor that runs each job at once on the caller's thread."""

    def __enter__(self) -> _Inline:
        return self

    def __exit__(self, *_: object) -> None:
        return None

    def submit(self, call: Callable[..., Any], *args: Any) -> Future:
        future: Future = Future()
        try:
            future.set_result(call(*args))
        except BaseException as error:  # handed to the caller, as an executor does
            future.set_exception(error)
        return future


@pytest.fixture
def update_both_ways(
    monkeypatch,
) -> Callable[[Callable[[], MAPPO], TrainBatch], tuple[dict, dict]]:
    """``update_both_ways(make, batch)``: one PPO update of ``batch`` by a fresh ``make()`` as
    the learner runs it (the critic's steps on its own thread, checked by forward hooks), and
    one with every step on this thread, critic first; returns each one's statistics and final
    parameters, keyed ``"threads"`` and ``"inline"``."""

    @contextlib.contextmanager
    def inline() -> Iterator[None]:
        with monkeypatch.context() as patch:
            patch.setattr(mappo, "_critic_thread", _Inline)
            yield

    def run(make: Callable[[], MAPPO], batch: TrainBatch) -> tuple[dict, dict]:
        results = {}
        for name, context in (("threads", contextlib.nullcontext), ("inline", inline)):
            learner = make()
            threads: set[str] = set()
            for module in learner.critic.modules():  # forward or a recurrent sequence
                module.register_forward_hook(
                    lambda *_, seen=threads: seen.add(threading.current_thread().name)
                )
            with context():
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
