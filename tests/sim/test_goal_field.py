"""Goal-field planning over an occupancy grid: starts a plan cannot begin from as they are."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from maopg.sim.planning import GoalFieldPlanner, OccupancyGrid


def _room() -> OccupancyGrid:
    """A 4 m x 4 m room at 0.1 m with a closed box (a free pocket inside a ring of blocked
    cells) around (1.0, 1.0): the shape a robot pushed between furniture and a wall sees."""
    blocked = np.zeros((41, 41), dtype=bool)
    blocked[5:16, 5] = blocked[5:16, 15] = True
    blocked[5, 5:16] = blocked[15, 5:16] = True
    return OccupancyGrid(origin=(0.0, 0.0), resolution=0.1, blocked=blocked)


def _segments_free(planner: GoalFieldPlanner, points: list[np.ndarray]) -> bool:
    return all(planner.visible(a, b) for a, b in itertools.pairwise(points))


def test_a_start_in_a_pocket_cut_off_from_the_goal_leaves_it_by_the_nearest_exit() -> None:
    planner = GoalFieldPlanner(_room())
    goal = (3.5, 3.5)
    path = planner.plan((1.0, 1.0), goal, radius=0.2)
    exit_point, rest = path[0], path[1:]
    # the nearest cell that reaches the goal lies just outside the box (1.0 m from its middle)
    assert math.dist(exit_point, (1.0, 1.0)) <= 0.65
    assert not (0.5 <= exit_point[0] <= 1.5 and 0.5 <= exit_point[1] <= 1.5)
    assert math.dist(path[-1], goal) <= 0.2 + 1e-9
    assert _segments_free(planner, [exit_point, *rest])


def test_a_start_inside_an_obstacle_goes_to_the_nearest_free_cell() -> None:
    grid = _room()
    grid.blocked[30, 5] = True  # one blocked cell under the start (0.5, 3.0)
    planner = GoalFieldPlanner(grid)
    path = planner.plan((0.5, 3.0), (3.5, 3.5), radius=0.2)
    assert math.dist(path[0], (0.5, 3.0)) == pytest.approx(0.1)
    assert _segments_free(planner, path)
    free_start = planner.plan((2.5, 2.5), (3.5, 3.5), radius=0.2)
    assert len(free_start) == 1 and math.dist(free_start[0], (3.5, 3.5)) <= 0.2 + 1e-9
