"""Grid path planning on the floor plane, around a compiled scene's static geometry.

Water Filling's ground vehicle must go around furniture; its PD tracker only drives straight
lines, so navigation options ask this planner for waypoints. The planner works on the compiled
``MjModel`` (no second description of the room): every collidable geom welded to the world whose
height range meets the robot's ``z_band`` is rasterised into an occupancy grid, inflated by the
robot's footprint radius (configuration space, so the robot is a point). A* over 8-connected
cells finds a shortest cell path; line-of-sight shortcutting turns it into a few straight
segments the tracking controller can follow.

Why not call :meth:`GridPlanner.plan` at every option start: a pure-Python A* plus its
line-of-sight shortcutting costs 10-40 ms on a 10 m room at 0.1 m, while a whole 0.5 s tick of
physics costs ~1 ms, so a navigation option would spend more time planning than simulating.
Tasks navigate to a handful of fixed goals (jars, workstations), so :class:`GoalFieldPlanner`
computes, once per goal, the exact cost-to-go of every cell of the same :class:`OccupancyGrid`
(8-connected, no corner cutting: the moves A* uses). A plan is then a descent of that field from
the start cell (optimal over the grid), shortened by vectorised line-of-sight checks — well
under a millisecond — and memoised per start cell. Fields are shared between task instances
built over the same grid. :class:`Route` holds the waypoints one robot is following.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

_SQRT2 = math.sqrt(2.0)
_NEIGHBOURS = tuple(
    (di, dj, _SQRT2 if di and dj else 1.0) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj
)


@dataclass(frozen=True)
class OccupancyGrid:
    """Cells a robot's centre may not occupy. ``blocked[i, j]`` is the cell at row y, column x."""

    origin: tuple[float, float]  # world (x, y) of the centre of cell (0, 0)
    resolution: float  # cell edge (m)
    blocked: np.ndarray  # bool, shape (ny, nx)

    def cell(self, xy: Sequence[float]) -> tuple[int, int]:
        """(row, column) of the cell containing a world point (may be outside the grid)."""
        return (
            round((xy[1] - self.origin[1]) / self.resolution),
            round((xy[0] - self.origin[0]) / self.resolution),
        )

    def center(self, cell: tuple[int, int]) -> np.ndarray:
        return np.array(
            [self.origin[0] + cell[1] * self.resolution, self.origin[1] + cell[0] * self.resolution]
        )

    def inside(self, cell: tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.blocked.shape[0] and 0 <= cell[1] < self.blocked.shape[1]

    def is_free(self, xy: Sequence[float]) -> bool:
        """True when a robot centred at ``xy`` keeps its clearance (outside the grid: False)."""
        c = self.cell(xy)
        return self.inside(c) and not self.blocked[c]

    def segment_free(self, a: Sequence[float], b: Sequence[float]) -> bool:
        """True when every point of the straight segment a-b is in a free cell."""
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        n = max(1, math.ceil(length / (0.25 * self.resolution)))
        for k in range(n + 1):
            t = k / n
            if not self.is_free((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]))):
                return False
        return True


def _static_obstacle_geoms(model: mujoco.MjModel, z_band: tuple[float, float]) -> list[int]:
    """Collidable, world-welded, non-plane geoms whose world z-range meets ``z_band``."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    out = []
    for g in range(model.ngeom):
        if model.body_weldid[model.geom_bodyid[g]] != 0:
            continue  # moves with a joint (robots, free props)
        if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0:
            continue  # visual only
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue  # the floor
        zmin, zmax = _world_aabb(model, data, g)[2]
        if zmax >= z_band[0] and zmin <= z_band[1]:
            out.append(g)
    return out


def _world_aabb(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> np.ndarray:
    """(3, 2) world axis-aligned bounds of a geom, from its local bounding box."""
    rot = data.geom_xmat[g].reshape(3, 3)
    center = data.geom_xpos[g] + rot @ model.geom_aabb[g, :3]
    half = np.abs(rot) @ model.geom_aabb[g, 3:]
    return np.stack([center - half, center + half], axis=1)


def occupancy_grid(
    model: mujoco.MjModel,
    *,
    radius: float,
    resolution: float = 0.1,
    z_band: tuple[float, float] = (0.02, 1.0),
    bounds: tuple[float, float, float, float] | None = None,
) -> OccupancyGrid:
    """Rasterise the static obstacles of ``model`` for a robot of footprint ``radius``.

    A cell is blocked when its centre is closer than ``radius + resolution / sqrt(2)`` to an
    obstacle's footprint, so *every* point of a free cell keeps ``radius`` of clearance.
    ``bounds`` = (xmin, xmax, ymin, ymax) defaults to the union of the obstacles' footprints
    (the walls, in a room). Upright boxes and round geoms use their exact footprint; anything
    tilted uses its (conservative) world bounding box.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    geoms = _static_obstacle_geoms(model, z_band)
    if bounds is None:
        if not geoms:
            raise ValueError("no static obstacles in the z band and no bounds given")
        boxes = np.array([_world_aabb(model, data, g)[:2] for g in geoms])
        bounds = (
            boxes[:, 0, 0].min(),
            boxes[:, 0, 1].max(),
            boxes[:, 1, 0].min(),
            boxes[:, 1, 1].max(),
        )
    xmin, xmax, ymin, ymax = bounds
    nx = math.floor((xmax - xmin) / resolution) + 1
    ny = math.floor((ymax - ymin) / resolution) + 1
    xs = xmin + resolution * np.arange(nx)
    ys = ymin + resolution * np.arange(ny)
    blocked = np.zeros((ny, nx), dtype=bool)
    clearance = radius + resolution / _SQRT2
    for g in geoms:
        aabb = _world_aabb(model, data, g)
        lo_x, hi_x = np.searchsorted(xs, [aabb[0, 0] - clearance, aabb[0, 1] + clearance])
        lo_y, hi_y = np.searchsorted(ys, [aabb[1, 0] - clearance, aabb[1, 1] + clearance])
        if lo_x >= hi_x or lo_y >= hi_y:
            continue
        px, py = np.meshgrid(xs[lo_x:hi_x], ys[lo_y:hi_y])
        dist = _footprint_distance(model, data, g, aabb, px, py)
        blocked[lo_y:hi_y, lo_x:hi_x] |= dist < clearance
    return OccupancyGrid(origin=(float(xmin), float(ymin)), resolution=resolution, blocked=blocked)


def _footprint_distance(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    g: int,
    aabb: np.ndarray,
    px: np.ndarray,
    py: np.ndarray,
) -> np.ndarray:
    """Planar distance from points to a geom's footprint (0 inside)."""
    rot = data.geom_xmat[g].reshape(3, 3)
    cx, cy = data.geom_xpos[g, 0], data.geom_xpos[g, 1]
    gtype = model.geom_type[g]
    size = model.geom_size[g]
    upright = abs(rot[2, 2]) > 0.999
    if upright and gtype == mujoco.mjtGeom.mjGEOM_BOX:
        # point in the box frame (rotation about z only), then distance to the rectangle
        lx = rot[0, 0] * (px - cx) + rot[1, 0] * (py - cy)
        ly = rot[0, 1] * (px - cx) + rot[1, 1] * (py - cy)
        dx = np.maximum(np.abs(lx) - size[0], 0.0)
        dy = np.maximum(np.abs(ly) - size[1], 0.0)
        return np.hypot(dx, dy)
    round_types = (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE)
    if gtype == mujoco.mjtGeom.mjGEOM_SPHERE or (upright and gtype in round_types):
        return np.maximum(np.hypot(px - cx, py - cy) - size[0], 0.0)
    dx = np.maximum(np.maximum(aabb[0, 0] - px, px - aabb[0, 1]), 0.0)
    dy = np.maximum(np.maximum(aabb[1, 0] - py, py - aabb[1, 1]), 0.0)
    return np.hypot(dx, dy)


class GridPlanner:
    """A* on an :class:`OccupancyGrid` with line-of-sight shortcutting."""

    def __init__(self, grid: OccupancyGrid) -> None:
        self.grid = grid

    @classmethod
    def for_model(
        cls,
        model: mujoco.MjModel,
        *,
        radius: float,
        resolution: float = 0.1,
        z_band: tuple[float, float] = (0.02, 1.0),
        bounds: tuple[float, float, float, float] | None = None,
    ) -> GridPlanner:
        return cls(
            occupancy_grid(
                model, radius=radius, resolution=resolution, z_band=z_band, bounds=bounds
            )
        )

    def nearest_free(self, xy: Sequence[float]) -> np.ndarray:
        """The free cell centre nearest to ``xy`` (``xy`` itself when it is free)."""
        grid = self.grid
        if grid.is_free(xy):
            return np.asarray(xy[:2], dtype=float)
        free = np.argwhere(~grid.blocked)
        if free.size == 0:
            raise ValueError("the occupancy grid has no free cell")
        centers = np.asarray(grid.origin) + grid.resolution * free[:, ::-1]
        return centers[np.argmin(np.hypot(*(centers - np.asarray(xy[:2])).T))]

    def plan(self, start: Sequence[float], goal: Sequence[float]) -> list[np.ndarray]:
        """Waypoints (after ``start``) of a collision-free path ending at or next to ``goal``.

        A start inside an inflated obstacle is first moved to the nearest free cell. A goal
        inside one (e.g. a jar on its stand) is replaced by the nearest free ring around it:
        the path ends at the first cell of that ring it reaches, i.e. on the near side of the
        jar. Raises ``ValueError`` when no path exists.
        """
        grid = self.grid
        s_xy = self.nearest_free(start)
        g_xy = np.asarray(goal[:2], dtype=float)
        if grid.is_free(g_xy):
            if grid.segment_free(s_xy, g_xy):
                return [g_xy]
            ring = 0.0
        else:
            ring = float(np.hypot(*(self.nearest_free(g_xy) - g_xy))) + grid.resolution
        cells = self._astar(grid.cell(s_xy), g_xy, ring)
        end = g_xy if ring == 0.0 else grid.center(cells[-1])
        points = [s_xy, *(grid.center(c) for c in cells[1:-1]), end]
        return self._shortcut(points)[1:]

    def _astar(
        self, start: tuple[int, int], goal: np.ndarray, ring: float
    ) -> list[tuple[int, int]]:
        """Shortest 8-connected cell path from ``start`` to a free cell within ``ring`` (m) of
        ``goal`` (the goal's own cell when ``ring`` is 0)."""
        grid = self.grid
        blocked = grid.blocked
        ny, nx = blocked.shape
        res = grid.resolution
        gx = (goal[0] - grid.origin[0]) / res  # goal in (fractional) cell units
        gy = (goal[1] - grid.origin[1]) / res
        goal_cell = grid.cell(goal)
        ring_cells = ring / res

        def h(c: tuple[int, int]) -> float:  # admissible: straight-line distance to the ring
            return max(0.0, math.hypot(c[0] - gy, c[1] - gx) - ring_cells)

        def reached(c: tuple[int, int]) -> bool:
            return c == goal_cell if ring == 0.0 else math.hypot(c[0] - gy, c[1] - gx) <= ring_cells

        cost = {start: 0.0}
        parent: dict[tuple[int, int], tuple[int, int]] = {}
        frontier = [(h(start), 0.0, start)]
        while frontier:
            _, c_cost, cur = heapq.heappop(frontier)
            if reached(cur):
                path = [cur]
                while cur in parent:
                    cur = parent[cur]
                    path.append(cur)
                return path[::-1]
            if c_cost > cost[cur]:
                continue
            i, j = cur
            for di, dj, step in _NEIGHBOURS:
                ni, nj = i + di, j + dj
                if not (0 <= ni < ny and 0 <= nj < nx) or blocked[ni, nj]:
                    continue
                if di and dj and (blocked[i + di, j] or blocked[i, j + dj]):
                    continue  # no corner cutting
                n_cost = c_cost + step
                if n_cost < cost.get((ni, nj), math.inf):
                    cost[(ni, nj)] = n_cost
                    parent[(ni, nj)] = cur
                    heapq.heappush(frontier, (n_cost + h((ni, nj)), n_cost, (ni, nj)))
        raise ValueError(f"no collision-free path from cell {start} to {tuple(goal)}")

    def _shortcut(self, points: list[np.ndarray]) -> list[np.ndarray]:
        """Greedy string pulling: from each kept point jump to the farthest visible one."""
        out = [points[0]]
        i = 0
        while i < len(points) - 1:
            j = len(points) - 1
            while j > i + 1 and not self.grid.segment_free(points[i], points[j]):
                j -= 1
            out.append(points[j])
            i = j
        return out


def path_length(start: Sequence[float], waypoints: Sequence[Sequence[float]]) -> float:
    """Length (m) of the polyline start -> waypoints."""
    pts = [start[:2], *(w[:2] for w in waypoints)]
    return float(sum(math.dist(a, b) for a, b in itertools.pairwise(pts)))


#: (grid fingerprint, goal, radius) -> (cost-to-go field, downhill moves); read-only once built.
_FIELDS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
_PATH_CACHE_SIZE = 50_000


def _shifted(a: np.ndarray, di: int, dj: int, fill: float | bool) -> np.ndarray:
    """``out[i, j] = a[i + di, j + dj]`` (``fill`` outside the array)."""
    out = np.full_like(a, fill)
    ny, nx = a.shape
    out[max(0, -di) : ny - max(0, di), max(0, -dj) : nx - max(0, dj)] = a[
        max(0, di) : ny - max(0, -di), max(0, dj) : nx - max(0, -dj)
    ]
    return out


def legal_moves(blocked: np.ndarray) -> list[tuple[int, int, float, np.ndarray]]:
    """Per move ``(di, dj, length, ok)``: ``ok[i, j]`` when the move from cell (i, j) is legal
    (both cells free and, for a diagonal, both orthogonal neighbours free: no corner cutting)."""
    free = ~blocked
    out = []
    for di, dj, step in _NEIGHBOURS:
        ok = free & _shifted(free, di, dj, False)
        if di and dj:
            ok &= _shifted(free, di, 0, False) & _shifted(free, 0, dj, False)
        out.append((di, dj, step, ok))
    return out


RELAXATION_CELLS = 20_000
"""Grids up to this many cells (a 14 m square room at 0.1 m) get their cost-to-go fields by
relaxation (:func:`relaxed_cost_to_go`), bigger ones by Dijkstra (:func:`dijkstra_cost_to_go`)."""


def cost_to_go(blocked: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Shortest 8-connected path length (in cells) from every free cell to any seed cell.

    Diagonal moves need both orthogonal neighbours free (no corner cutting), as in
    :class:`GridPlanner`. Blocked or unreachable cells are ``inf``. Both methods give the same
    field to the bit (each cell's value is the least fixed point of ``min(neighbour + move)``,
    summed outward from the seeds, whatever order finds it). The relaxation's cost grows with
    the cells times the longest path, Dijkstra's with the cells; ``python
    bench/perf/cost_to_go.py`` times both per room size.
    """
    if blocked.size <= RELAXATION_CELLS:
        return relaxed_cost_to_go(blocked, seeds)
    return dijkstra_cost_to_go(blocked, seeds)


def relaxed_cost_to_go(blocked: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """:func:`cost_to_go` by Bellman-Ford relaxation over whole-array shifts: about a hundred
    numpy sweeps on a room-sized grid."""
    field = np.where(seeds & ~blocked, 0.0, np.inf)
    allowed = legal_moves(blocked)
    while True:
        before = field
        for di, dj, step, ok in allowed:
            cand = _shifted(field, di, dj, np.inf) + step
            field = np.where(ok & (cand < field), cand, field)
        if np.array_equal(field, before):
            return field


def dijkstra_cost_to_go(blocked: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """:func:`cost_to_go` by multi-source Dijkstra over the grid's legal moves, walked backwards
    (a settled cell offers its cost plus the move's length to each cell that may move to it:
    the very sum the relaxation takes, so the two agree to the bit), settling a band at a time.

    Every move is at least 1 long, so no path through an unsettled cell can bring a cell below
    ``m + 1``, ``m`` the least cost still open: each round settles every open cell under it at
    once (Dial's buckets, one unit wide) and relaxes the band's moves as numpy index arrays.
    Rounds grow with the longest path, each with the band's cells, not the grid's
    (``bench/perf/cost_to_go.py`` times it beside the relaxation and scipy's Dijkstra, which
    did this before)."""
    ny, nx = blocked.shape
    # A blocked border: every neighbour of a free cell is then inside the flat array, and the
    # flat index of a move, cell + di * width + dj, never wraps onto another row.
    walled = np.ones((ny + 2, nx + 2), dtype=bool)
    walled[1:-1, 1:-1] = blocked
    width = nx + 2
    moves = [(di * width + dj, step, ok.ravel()) for di, dj, step, ok in legal_moves(walled)]
    sources = np.zeros_like(walled)
    sources[1:-1, 1:-1] = seeds & ~blocked
    field = np.full(walled.size, np.inf)
    seen = np.zeros(walled.size, dtype=bool)  # given a finite cost, settled or not
    frontier = np.flatnonzero(sources)  # seen, not settled
    field[frontier] = 0.0
    seen[frontier] = True
    while frontier.size:
        costs = field[frontier]
        band = costs < costs.min() + 1.0
        settled, frontier = frontier[band], frontier[~band]
        for offset, step, ok in moves:
            legal = ok[settled - offset]  # the cells that may move onto a settled one
            ends = settled[legal]
            before = ends - offset  # distinct: one move, distinct ends
            field[before] = np.minimum(field[before], field[ends] + step)
            new = before[~seen[before]]
            seen[new] = True
            frontier = np.concatenate([frontier, new])
    return field.reshape(walled.shape)[1:-1, 1:-1].copy()


def _downhill(field: np.ndarray, blocked: np.ndarray) -> np.ndarray:
    """Per cell, the index into ``_NEIGHBOURS`` of its best legal neighbour, for every reachable
    cell outside the goal disc (``field > 0``; -1 elsewhere): following it from any cell traces
    a shortest grid path into the disc."""
    best = np.full(field.shape, np.inf)
    move = np.zeros(field.shape, dtype=np.int8)
    for k, (di, dj, step, ok) in enumerate(legal_moves(blocked)):
        cand = np.where(ok, _shifted(field, di, dj, np.inf) + step, np.inf)
        better = cand < best
        best[better] = cand[better]
        move[better] = k
    move[~(np.isfinite(field) & (field > 0.0))] = -1
    return move


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

    def _tables(self, goal: Sequence[float], radius: float) -> tuple[np.ndarray, np.ndarray]:
        """(cost-to-go field, downhill move of every reachable cell outside the disc)."""
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
            downhill = _downhill(field, grid.blocked)
            field.flags.writeable = downhill.flags.writeable = False
            tables = _FIELDS[key] = (field, downhill)
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

    def _descend(self, cell: tuple[int, int], field: np.ndarray, downhill: np.ndarray):
        """Follow the field downhill from ``cell`` (a reachable one) to the goal disc, then
        shortcut."""
        cells = [cell]
        while (k := downhill[cell]) >= 0:
            di, dj, _ = _NEIGHBOURS[k]
            cell = (cell[0] + di, cell[1] + dj)
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
        return path_length(xy, self.waypoints[self.index :])
