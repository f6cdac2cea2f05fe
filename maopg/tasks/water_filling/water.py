"""The jars' random water dynamics and the reward on their levels (no physics involved)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from maopg.tasks.water_filling.config import Config


def jar_reward(levels: Sequence[float] | np.ndarray, eps: float = 0.001) -> float:
    """Paper Eq. 6: ``sum_c (1 - 1 / (w_c + eps))`` over the true levels."""
    return float(sum(1.0 - 1.0 / (float(w) + eps) for w in levels))


class WaterLevels:
    """Each jar counts down an interval ``round(Exp(scale=s))`` ticks, ``s`` drawn with
    ``rng.integers(*interval_scale)``; on expiry the level drops by
    ``|N(interval * drop_mean_per_tick, drop_std)|``, clipped at 0, and a new interval is drawn.
    Every jar (``config.jars`` of them) has its own numpy ``Generator`` spawned from the reset
    seed: jar ``c``'s stream is the same whatever the number of jars."""

    def __init__(self, config: Config) -> None:
        self.config = config
        self.num_jars = config.jars
        self.levels = np.ones(self.num_jars)
        self.reset(0)

    def reset(self, seed: int) -> None:
        streams = np.random.SeedSequence(seed).spawn(self.num_jars)
        self._rngs = [np.random.default_rng(s) for s in streams]
        self.levels[:] = 1.0
        self._interval = [self._draw_interval(c) for c in range(self.num_jars)]
        self._left = list(self._interval)

    def _draw_interval(self, jar: int) -> int:
        rng = self._rngs[jar]
        scale = int(rng.integers(*self.config.interval_scale))
        return round(rng.exponential(scale))

    def step(self) -> None:
        """One tick of every jar's countdown; expired jars drop and draw a new interval."""
        c = self.config
        for jar in range(self.num_jars):
            self._left[jar] -= 1
            if self._left[jar] > 0:
                continue
            interval = self._interval[jar]
            drop = abs(self._rngs[jar].normal(interval * c.drop_mean_per_tick, c.drop_std))
            self.levels[jar] = max(0.0, self.levels[jar] - drop)
            self._interval[jar] = self._draw_interval(jar)
            self._left[jar] = self._interval[jar]

    def fill(self, jar: int) -> None:
        self.levels[jar] = 1.0
