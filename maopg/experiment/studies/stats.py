"""The statistics the studies report over few seeds: a percentile bootstrap interval of a mean,
Fisher's exact test of two proportions, the interquartile mean, its stratified bootstrap
interval across tasks, and performance profiles (Agarwal et al., "Deep RL at the edge of the
statistical precipice", NeurIPS 2021).

Written here rather than taken from ``rliable`` or ``scipy``: each is a few lines, the studies
need them exactly reproducible (a fixed generator, ``numpy`` only), and neither library is a
dependency of the core.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

RESAMPLES = 10_000
"""Bootstrap resamples of every interval: the 2.5 % and 97.5 % percentiles of 10,000 resampled
statistics move by less than 1 % of the interval's width between generator seeds."""
LEVEL = 0.95
"""The confidence of every interval."""


def bootstrap_interval(
    values: Sequence[float], *, level: float = LEVEL, resamples: int = RESAMPLES, seed: int = 0
) -> tuple[float, float]:
    """The percentile bootstrap interval of the mean of ``values``: resample them with
    replacement ``resamples`` times and take the central ``level`` of the resampled means.
    With 5 values it is the range the mean of 5 seeds drawn like them would cover."""
    data = np.asarray(values, dtype=np.float64)
    if data.size == 0:
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    means = data[rng.integers(0, data.size, (resamples, data.size))].mean(axis=1)
    tail = (1 - level) / 2 * 100
    low, high = np.percentile(means, [tail, 100 - tail])
    return float(low), float(high)


def fisher_exact(hits_a: int, n_a: int, hits_b: int, n_b: int) -> float:
    """Two-sided p-value of Fisher's exact test that two groups (``hits_a`` of ``n_a``,
    ``hits_b`` of ``n_b``) share one proportion: the probability, given the margins, of a
    table at most as likely as the one seen (the rule of R's ``fisher.test`` and of
    ``scipy.stats.fisher_exact``, relative tolerance 1e-7)."""
    hits = hits_a + hits_b
    total = n_a + n_b

    def probability(k: int) -> float:
        return math.comb(n_a, k) * math.comb(n_b, hits - k) / math.comb(total, hits)

    seen = probability(hits_a)
    tables = range(max(0, hits - n_b), min(n_a, hits) + 1)
    return min(1.0, sum(p for k in tables if (p := probability(k)) <= seen * (1 + 1e-7)))


def iqm(values: np.ndarray) -> float:
    """The interquartile mean: the mean of ``values`` (all runs of all tasks pooled) with the
    lowest and highest quarter left out, ``floor(n / 4)`` runs each, as ``rliable`` computes it
    (``scipy.stats.trim_mean(values, 0.25)``)."""
    data = np.sort(np.asarray(values, dtype=np.float64).ravel())
    if data.size == 0:
        return math.nan
    cut = data.size // 4
    return float(data[cut : data.size - cut].mean())


def stratified_bootstrap_interval(
    scores: Sequence[np.ndarray],
    statistic=iqm,
    *,
    level: float = LEVEL,
    resamples: int = RESAMPLES,
    seed: int = 0,
) -> tuple[float, float]:
    """The percentile interval of ``statistic`` over the runs of all tasks, each resample
    drawing every task's runs with replacement within that task (``scores``: one array of
    per-seed normalised scores a task), so that every task keeps its number of runs. The pooled
    statistic weighs a task by its runs: ``rliable``'s tasks have equal runs, and where they do
    not (a board of 3 seeds beside boards of 5) a task of fewer runs weighs less."""
    rng = np.random.default_rng(seed)
    draws = np.empty(resamples)
    for r in range(resamples):
        draws[r] = statistic(
            np.concatenate([s[rng.integers(0, s.size, s.size)] for s in scores if s.size])
        )
    tail = (1 - level) / 2 * 100
    low, high = np.percentile(draws, [tail, 100 - tail])
    return float(low), float(high)


def performance_profile(scores: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """The fraction of runs whose normalised score exceeds each threshold τ (the run-score
    distribution of Agarwal et al.)."""
    data = np.asarray(scores, dtype=np.float64).ravel()
    return (data[None, :] > np.asarray(thresholds)[:, None]).mean(axis=1)
