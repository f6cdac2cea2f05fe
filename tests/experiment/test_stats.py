"""The studies' statistics (maopg.experiment.studies.stats) against hand-worked cases."""

from __future__ import annotations

import numpy as np
import pytest

from maopg.experiment.studies.stats import (
    bootstrap_interval,
    fisher_exact,
    iqm,
    performance_profile,
    stratified_bootstrap_interval,
)


def test_fisher_exact_is_the_two_sided_test_of_the_textbook_tables():
    # The lady tasting tea: 3 of 4 against 1 of 4, p = 34/70.
    assert fisher_exact(3, 4, 1, 4) == pytest.approx(34 / 70)
    # 0 of 5 against 5 of 5: the two extreme tables of C(10, 5) = 252, p = 2/252.
    assert fisher_exact(0, 5, 5, 5) == pytest.approx(2 / 252)
    # 3 of 5 against 5 of 5: margins 8 of 10; tables k = 3, 4, 5 have 10, 25, 10 of 45.
    assert fisher_exact(3, 5, 5, 5) == pytest.approx(20 / 45)
    assert fisher_exact(5, 5, 5, 5) == 1.0
    assert fisher_exact(2, 5, 2, 5) == pytest.approx(1.0)


def test_a_bootstrap_interval_covers_the_mean_and_repeats_with_its_seed():
    values = [1.0, 2.0, 3.0, 4.0, 10.0]
    low, high = bootstrap_interval(values)
    assert 1.0 < low < np.mean(values) < high < 10.0
    assert bootstrap_interval(values) == (low, high)
    assert bootstrap_interval([299.3] * 5) == pytest.approx((299.3, 299.3))
    # The interval of 5 values lies within their extremes' mean range: every resample's mean.
    assert bootstrap_interval([0.0, 0.0, 0.0, 0.0, 5.0], level=1.0) == (0.0, 5.0)


def test_the_interquartile_mean_drops_a_quarter_of_the_runs_at_each_end():
    assert iqm(np.arange(1.0, 9.0)) == 4.5  # 3, 4, 5, 6
    assert iqm(np.array([100.0, 1.0, 2.0, 3.0, -50.0])) == 2.0  # 1, 2, 3
    assert iqm(np.array([7.0, 9.0])) == 8.0  # fewer than 4: nothing to drop


def test_a_stratified_bootstrap_resamples_within_each_task():
    tasks = [np.array([1.0, 1.0, 1.0]), np.array([0.0, 0.0])]
    # Every resample keeps 3 ones and 2 zeros: the IQM of (0, 0, 1, 1, 1) drops one of each.
    assert stratified_bootstrap_interval(tasks, resamples=50) == pytest.approx((2 / 3, 2 / 3))
    low, high = stratified_bootstrap_interval([np.array([0.0, 1.0, 2.0, 3.0])], np.mean)
    assert 0.0 < low < 1.5 < high < 3.0


def test_a_performance_profile_is_the_share_of_runs_above_each_threshold():
    scores = np.array([0.0, 0.5, 1.0, 1.5])
    assert performance_profile(scores, np.array([-1.0, 0.25, 1.0, 2.0])).tolist() == [
        1.0,
        0.75,
        0.25,
        0.0,
    ]
