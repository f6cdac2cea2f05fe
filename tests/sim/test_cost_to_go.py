"""The planners' cost-to-go fields: a hand-worked grid, and both methods equal to the bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from maopg.sim.planning import cost_to_go, dijkstra_cost_to_go, relaxed_cost_to_go

INF = math.inf
R2 = math.sqrt(2.0)


def _hand_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(blocked, seeds, field)``: the seed S in a 4 x 5 room split by a wall (#) with a
    blocked cell beside it, the field worked out by hand. A diagonal move needs both orthogonal
    neighbours free, so no path cuts the blocked cell's corners: the cells above it are reached
    the long way round, and the column behind the wall not at all::

        . . . # .        2   3    4     inf inf
        . # . # .        1   inf  3     inf inf
        S . . # .        0   1    2     inf inf
        . . . # .        1   √2   1+√2  inf inf
    """
    blocked = np.zeros((4, 5), dtype=bool)
    blocked[:, 3] = True
    blocked[1, 1] = True
    seeds = np.zeros_like(blocked)
    seeds[2, 0] = True
    field = np.array(
        [
            [2, 3, 4, INF, INF],
            [1, INF, 3, INF, INF],
            [0, 1, 2, INF, INF],
            [1, R2, 1 + R2, INF, INF],
        ]
    )
    return blocked, seeds, field


@pytest.mark.parametrize("method", [dijkstra_cost_to_go, relaxed_cost_to_go, cost_to_go])
def test_every_method_gives_the_hand_worked_field(method) -> None:
    blocked, seeds, field = _hand_grid()
    assert np.array_equal(method(blocked, seeds), field)


def test_a_seed_on_a_blocked_cell_reaches_nothing() -> None:
    blocked, _, _ = _hand_grid()
    seeds = blocked.copy()
    assert np.isinf(dijkstra_cost_to_go(blocked, seeds)).all()


def test_dijkstra_and_the_relaxation_agree_to_the_bit_on_random_rooms() -> None:
    """Path lengths are sums of 1 and √2 in many orders; the planner's waypoints follow the
    field's exact values, so a field one ulp off would change the trajectories."""
    rng = np.random.default_rng(0)
    for shape in [(1, 1), (7, 13), (40, 25), (60, 60)]:
        blocked = rng.random(shape) < 0.25
        seeds = np.zeros(shape, dtype=bool)
        seeds.flat[rng.choice(blocked.size, size=min(3, blocked.size), replace=False)] = True
        field = dijkstra_cost_to_go(blocked, seeds)
        assert np.array_equal(field, relaxed_cost_to_go(blocked, seeds))
        assert field.shape == shape
