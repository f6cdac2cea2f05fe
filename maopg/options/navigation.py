"""Navigation building blocks for options: goal-field path planning and waypoint tracking.

Why not call :meth:`maopg.sim.planning.GridPlanner.plan` at every option start: a pure-Python
A* plus its line-of-sight shortcutting costs 10-40 ms on a 10 m room at 0.1 m, while a whole
0.5 s tick of physics costs ~1 ms, so a NavTo option would spend more time planning than
simulating. Tasks navigate to a handful of fixed goals (jars, workstations), so
:class:`GoalFieldPlanner` computes, once per goal, the exact cost-to-go of every cell of the
same :class:`~maopg.sim.planning.OccupancyGrid` (8-connected, no corner cutting: the moves
A* uses). A plan is then a descent of that field from the start cell (optimal over the grid),
shortened by vectorised line-of-sight checks — well under a millisecond — and memoised per
start cell. Fields are shared between task instances built over the same grid.

:class:`Route` follows the waypoints with a robot's own tracking controller (``drive_to`` /
``fly_to``), one command per tick.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from maopg.sim.planning import GridPlanner, OccupancyGrid

_SQRT2 = math.sqrt(2.0)
_MOVES = tuple(
    (di, dj, _SQRT2 if di and dj else 1.0) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj
)
#: (grid fingerprint, goal, radius) -> (cost-to-go field, downhill table); read-only once built.
_FIELDS: dict[tuple, tuple[np.ndarray, dict]] = {}
_PATH_CACHE_SIZE = 50_000


def _shifted(a: np.ndarray, di: int, dj: int, fill: float | bool) -> np.ndarray:
    """``out[i, j] = a[i + di, j + dj]`` (``fill`` outside the array)."""
    out = np.full_like(a, fill)
    ny, nx = a.shape
    out[max(0, -di) : ny - max(0, di), max(0, -dj) : nx - max(0, dj)] = a[
        max(0, di) : ny - max(0, -di), max(0, dj) : nx - max(0, -dj)
    ]
    return out


def _allowed_moves(blocked: np.ndarray) -> list[tuple[int, int, float, np.ndarray]]:
    """Per move ``(di, dj, length, ok)``: ``ok[i, j]`` when the move from cell (i, j) is legal
    (both cells free and, for a diagonal, both orthogonal neighbours free: no corner cutting)."""
    free = ~blocked
    out = []
    for di, dj, step in _MOVES:
        ok = free & _shifted(free, di, dj, False)
        if di and dj:
            ok &= _shifted(free, di, 0, False) & _shifted(free, 0, dj, False)
        out.append((di, dj, step, ok))
    return out


def cost_to_go(blocked: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Shortest 8-connected path length (in cells) from every free cell to any seed cell.

    Diagonal moves need both orthogonal neighbours free (no corner cutting), as in
    :class:`GridPlanner`. Computed by Bellman-Ford relaxation over whole-array shifts:
    exact, and about a hundred numpy sweeps on a room-sized grid. Blocked or unreachable
    cells are ``inf``.
    """
    field = np.where(seeds & ~blocked, 0.0, np.inf)
    allowed = _allowed_moves(blocked)
    while True:
        before = field
        for di, dj, step, ok in allowed:
            cand = _shifted(field, di, dj, np.inf) + step
            field = np.where(ok & (cand < field), cand, field)
        if np.array_equal(field, before):
            return field


def _downhill(field: np.ndarray, blocked: np.ndarray) -> dict[tuple[int, int], tuple[int, int]]:
    """The best legal neighbour of every reachable cell outside the goal disc (``field > 0``):
    following it from any cell traces a shortest grid path into the disc."""
    best = np.full(field.shape, np.inf)
    move = np.zeros(field.shape, dtype=np.int8)
    for k, (di, dj, step, ok) in enumerate(_allowed_moves(blocked)):
        cand = np.where(ok, _shifted(field, di, dj, np.inf) + step, np.inf)
        better = cand < best
        best[better] = cand[better]
        move[better] = k
    table = {}
    for i, j in zip(*np.nonzero(np.isfinite(field) & (field > 0.0)), strict=True):
        di, dj, _ = _MOVES[move[i, j]]
        table[(int(i), int(j))] = (int(i) + di, int(j) + dj)
    return table


class GoalFieldPlanner:
    """Collision-free paths to fixed goals over an occupancy grid (see the module docstring).

    A goal is reached anywhere within ``radius`` (m) of it: the path ends at the first free
    cell of that disc it meets, on the near side (a jar on its stand, a spot to hover over).
    """

    def __init__(self, grid: OccupancyGrid) -> None:
        self.grid = grid
        self._fallback = GridPlanner(grid)  # nearest_free for starts inside an obstacle
        self._key = (hash(grid.blocked.tobytes()), grid.blocked.shape, grid.origin, grid.resolution)
        self._paths: dict[tuple, list[np.ndarray]] = {}

    def field(self, goal: Sequence[float], radius: float) -> np.ndarray:
        """The (cached) cost-to-go field of a goal disc, in cells."""
        return self._tables(goal, radius)[0]

    def _tables(self, goal: Sequence[float], radius: float) -> tuple[np.ndarray, dict]:
        """(cost-to-go field, downhill successor of every reachable cell outside the disc)."""
        key = (*self._key, round(float(goal[0]), 6), round(float(goal[1]), 6), float(radius))
        tables = _FIELDS.get(key)
        if tables is None:
            grid = self.grid
            ny, nx = grid.blocked.shape
            xs = grid.origin[0] + grid.resolution * np.arange(nx)
            ys = grid.origin[1] + grid.resolution * np.arange(ny)
            seeds = np.hypot(xs[None, :] - goal[0], ys[:, None] - goal[1]) <= radius
            if not (seeds & ~grid.blocked).any():
                raise ValueError(
                    f"no free cell within {radius} m of goal {tuple(goal)}: increase the radius"
                )
            field = cost_to_go(grid.blocked, seeds)
            field.flags.writeable = False
            tables = _FIELDS[key] = (field, _downhill(field, grid.blocked))
        return tables

    def plan(
        self, start: Sequence[float], goal: Sequence[float], radius: float
    ) -> list[np.ndarray]:
        """Waypoints (after ``start``) ending within ``radius`` of ``goal``.

        A start inside an inflated obstacle first goes to the nearest free cell from which the
        goal disc can be reached (see :meth:`_entry`).
        """
        grid = self.grid
        field, downhill = self._tables(goal, radius)
        s_xy = self._entry(start, field)
        cell = grid.cell(s_xy)
        key = (cell, round(float(goal[0]), 6), round(float(goal[1]), 6), float(radius))
        path = self._paths.get(key)
        if path is None:
            path = self._descend(cell, field, downhill)
            if len(self._paths) >= _PATH_CACHE_SIZE:
                self._paths.clear()
            self._paths[key] = path
        if s_xy[0] != start[0] or s_xy[1] != start[1]:  # moved out of an obstacle first
            return [s_xy, *path]
        return list(path)

    def _entry(self, start: Sequence[float], field: np.ndarray) -> np.ndarray:
        """Where the path starts: ``start`` itself, or — for a robot pushed into an inflated
        obstacle — the nearest free cell centre, unless that cell lies in a free pocket cut
        off from the goal (between a wall and furniture, say), in which case the nearest cell
        that reaches the goal. Reachable cells always exist (``_tables`` checks the disc)."""
        s_xy = self._fallback.nearest_free(start)
        if math.isfinite(field[self.grid.cell(s_xy)]):
            return s_xy
        reachable = np.argwhere(np.isfinite(field))
        centers = np.asarray(self.grid.origin) + self.grid.resolution * reachable[:, ::-1]
        return centers[np.argmin(np.hypot(*(centers - np.asarray(start[:2])).T))]

    def _descend(self, cell: tuple[int, int], field: np.ndarray, downhill: dict):
        """Follow the field downhill from ``cell`` (a reachable one) to the goal disc, then
        shortcut."""
        cells = [cell]
        while cell in downhill:
            cell = downhill[cell]
            cells.append(cell)
        points = np.array([self.grid.center(c) for c in cells])
        if len(points) == 1:  # already in the goal disc: the route is the start cell's centre
            return [points[0]]
        return [points[k] for k in self._shortcut(points)[1:]]

    def visible(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Every point of segment a-b lies in a free cell (vectorised ``segment_free``)."""
        grid = self.grid
        n = max(1, math.ceil(math.dist(a, b) / (0.25 * grid.resolution)))
        t = np.arange(n + 1) / n
        cols = np.rint((a[0] - grid.origin[0] + t * (b[0] - a[0])) / grid.resolution)
        rows = np.rint((a[1] - grid.origin[1] + t * (b[1] - a[1])) / grid.resolution)
        ny, nx = grid.blocked.shape
        if min(cols[0], cols[-1]) < 0 or min(rows[0], rows[-1]) < 0:
            return False  # the ends are the extremes of a segment
        if max(cols[0], cols[-1]) >= nx or max(rows[0], rows[-1]) >= ny:
            return False
        return not grid.blocked[rows.astype(np.intp), cols.astype(np.intp)].any()

    def _shortcut(self, points: np.ndarray) -> list[int]:
        """Indices of kept points: from each, jump to a far visible point (galloping search,
        then bisection; every kept segment is checked, so the path stays collision-free)."""
        keep = [0]
        last = len(points) - 1
        i = 0
        while i < last:
            if self.visible(points[i], points[last]):  # the common case in open space
                keep.append(last)
                break
            lo, step = i + 1, 1  # lo: known visible from i (adjacent cells always are)
            while lo + step < last and self.visible(points[i], points[lo + step]):
                lo += step
                step *= 2
            hi = min(lo + step, last)  # first index not shown visible
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if self.visible(points[i], points[mid]):
                    lo = mid
                else:
                    hi = mid
            keep.append(lo)
            i = lo
        return keep


@dataclass
class Route:
    """Waypoints being followed by one robot: one tracking command per tick.

    An intermediate waypoint counts as passed within ``pass_tol`` (m); the route is finished
    when the robot is within ``arrive_tol`` of the last one.
    """

    waypoints: list[np.ndarray]
    arrive_tol: float
    pass_tol: float
    index: int = 0

    @property
    def target(self) -> np.ndarray:
        return self.waypoints[self.index]

    @property
    def last_leg(self) -> bool:
        return self.index == len(self.waypoints) - 1

    def update(self, xy: Sequence[float]) -> bool:
        """Advance past reached waypoints; True when the final one is reached."""
        while not self.last_leg and math.dist(xy[:2], self.target) <= self.pass_tol:
            self.index += 1
        return self.last_leg and math.dist(xy[:2], self.target) <= self.arrive_tol

    def length_from(self, xy: Sequence[float]) -> float:
        """Remaining path length (m) from ``xy`` through the waypoints still ahead."""
        pts = [np.asarray(xy[:2], dtype=float), *self.waypoints[self.index :]]
        return float(sum(math.dist(a, b) for a, b in itertools.pairwise(pts)))
