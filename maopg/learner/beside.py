"""The critic's computation on a thread of its own beside the actor's, or one after the other.

Actor and critic share no tensor that either writes (separate networks, optimisers and losses;
what both read is fixed before), so the critic's part may run on a second thread while the
actor's runs on the caller's: torch releases the GIL inside its kernels, so the two overlap on
two cores, and each computes exactly what it would alone, in the same order — the same bits as
one after the other. :class:`~maopg.learner.mappo.MAPPO` runs each PPO step so: measured side
by side in one run (``bench/perf/learner_plumbing.py``, BENCHMARKS.md), an update takes 1.84x
less time from Water Filling RGB, 1.63x from Tool Delivery RGB, 1.13-1.26x from state. The
collection once valued each new decision point this way while the policy decided there; it
gained nothing measurable (0.95-1.04x, within the noise, on the same four cases) and runs one
after the other.

Why a new thread for each update and each collection, and why it sets its torch thread count at
start: a new thread starts at OpenMP's default (every core), and torch applies
``torch.set_num_threads`` to a thread only lazily, at the first operation that asks for it; a
GRU's small steps never do. A recurrent critic's first steps on a new thread then ran on two
OpenMP threads and its later ones on one, so its bits depended on the thread's past and on
``OMP_NUM_THREADS`` (a recurrent run resumed in a new process left the uninterrupted run's value
loss in the seventh digit). Nothing a thread holds outlives its update or collection; starting
one costs well under a millisecond.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

import torch

C = TypeVar("C")
A = TypeVar("A")


class Beside:
    """``with Beside(threaded) as beside: critics, actors = beside.run(critic, actor)`` — the
    critic's callable on its own thread (``threaded``) or first on this one."""

    def __init__(self, threaded: bool = True) -> None:
        self.threaded = threaded
        self._pool: ThreadPoolExecutor | None = None

    def __enter__(self) -> Beside:
        if self.threaded:
            self._pool = ThreadPoolExecutor(
                1, thread_name_prefix="maopg-critic", initializer=_same_threads
            )
        return self

    def __exit__(self, *_: object) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def run(self, critic: Callable[[], C], actor: Callable[[], A]) -> tuple[C, A]:
        """``(critic(), actor())``; if the actor's part raises, the critic's is let end first
        and the actor's error wins."""
        if self._pool is None:
            return critic(), actor()
        job = self._pool.submit(critic)
        try:
            acted = actor()
        except BaseException:
            job.exception()
            raise
        return job.result(), acted


def _same_threads() -> None:
    """Apply the process's torch thread count to this thread now (module docstring)."""
    torch.set_num_threads(torch.get_num_threads())
