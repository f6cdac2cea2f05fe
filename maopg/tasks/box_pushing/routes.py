"""Routes of the GoTo macro-actions around the boxes and the teammates, as they stand now.

The boxes are free bodies that pushes move (and may turn), so the static-geometry planner of
:mod:`maopg.sim.planning` does not see them. The arena is a grid of at most 10 x 10 cells, so a
route is planned the grid's way, on cells: a breadth-first search over the 4-connected cells a
robot may stand on (its footprint clear of every box, teammate and wall), from the robot's cell
to the waypoint's; then string-pulled into straight legs wherever the robot's swept footprint
stays clear (a robot crossing open floor drives straight, diagonally, where the grid walks an
L). Planning costs well under a millisecond, once per GoTo.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from maopg.tasks.box_pushing.arena import Arena

SAMPLE = 0.05
"""m between the points of a leg whose clearance is checked."""
MARGIN = 0.02
"""m a route keeps between a robot's footprint and anything else."""


@dataclass(frozen=True)
class Obstacles:
    """What a route keeps clear of: boxes as rectangles, teammates as discs."""

    boxes: np.ndarray
    """``[B, 5]``: centre x, y, half length (along the box's yaw), half width, yaw."""
    discs: np.ndarray
    """``[M, 3]``: centre x, y, radius."""

    def clear(self, points: np.ndarray, radius: float, side: float) -> np.ndarray:
        """Which of ``points [N, 2]`` a robot of footprint ``radius`` may stand on, keeping
        ``MARGIN`` from every box and teammate and staying inside the walls of a ``side``-metre
        arena."""
        reach = radius + MARGIN
        ok = ((points >= reach) & (points <= side - reach)).all(axis=1)
        for x, y, half_l, half_w, yaw in self.boxes:
            dx, dy = points[:, 0] - x, points[:, 1] - y
            c, s = math.cos(yaw), math.sin(yaw)
            along = np.maximum(np.abs(c * dx + s * dy) - half_l, 0.0)
            across = np.maximum(np.abs(-s * dx + c * dy) - half_w, 0.0)
            ok &= np.hypot(along, across) > reach
        for x, y, r in self.discs:
            ok &= np.hypot(points[:, 0] - x, points[:, 1] - y) > reach + r
        return ok


def plan(
    arena: Arena,
    start: Sequence[float],
    goal: Sequence[float],
    obstacles: Obstacles,
    radius: float,
) -> list[np.ndarray]:
    """Waypoints (after ``start``) to ``goal``, a cell centre; straight to the goal when no
    clear cell path exists (a box sits on the waypoint: the GoTo then runs into it and its
    deadline ends it)."""
    start = np.asarray(start[:2], dtype=float)
    goal = np.asarray(goal[:2], dtype=float)
    n = arena.size
    first = tuple(min(max(v, 0), n - 1) for v in arena.cell_of(start))
    last = arena.cell_of(goal)
    cells = [(i, j) for i in range(n) for j in range(n)]
    centres = np.array([arena.centre(c) for c in cells])
    free = dict(zip(cells, obstacles.clear(centres, radius, arena.side), strict=True))
    parent: dict[tuple[int, int], tuple[int, int]] = {first: first}
    frontier = deque([first])
    while frontier and last not in parent:
        i, j = frontier.popleft()
        for step in ((i, j + 1), (i + 1, j), (i, j - 1), (i - 1, j)):  # N, E, S, W: the grid's
            if arena.inside(step) and step not in parent and (free[step] or step == last):
                parent[step] = (i, j)
                frontier.append(step)
    if last not in parent:
        return [goal]
    path = [last]
    while path[-1] != first:
        path.append(parent[path[-1]])
    points = [start, *(arena.centre(c) for c in reversed(path[1:])), goal]
    return _pull(points, obstacles, radius, arena.side)


def _pull(
    points: list[np.ndarray], obstacles: Obstacles, radius: float, side: float
) -> list[np.ndarray]:
    """Greedy string pulling: from each kept point, on to the farthest one in clear sight
    (neighbouring cells are always in sight: the search found them clear)."""
    kept, i = [], 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not _leg_clear(points[i], points[j], obstacles, radius, side):
            j -= 1
        kept.append(points[j])
        i = j
    return kept or [points[-1]]


def _leg_clear(
    a: np.ndarray, b: np.ndarray, obstacles: Obstacles, radius: float, side: float
) -> bool:
    """Every point of the leg a-b past ``a`` is clear (``a`` itself may be a robot pressed
    against a box, whose way out starts there)."""
    steps = max(1, math.ceil(math.dist(a, b) / SAMPLE))
    t = np.arange(1, steps + 1)[:, None] / steps
    return bool(obstacles.clear(a + t * (b - a), radius, side).all())
