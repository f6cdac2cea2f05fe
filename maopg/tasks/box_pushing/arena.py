"""The grid's layout in metres: where everything of a Box Pushing arena stands (plain data).

The arena is the canonical grid (:class:`maopg.tasks.box_pushing_grid.world.Layout`, in cells:
starts, boxes, waypoints, the goal row) scaled by ``cell_size``: cell ``(i, j)`` spans
``[i c, (i + 1) c] x [j c, (j + 1) c]``, x east, y north, walls on the square's four sides. The
goal strip is the top row of cells; a box whose centre enters it is delivered.

A robot's *heading* is its yaw rounded to the nearest compass direction (the grid's
orientation codes, 0..3 = N, E, S, W); the cell *in front* of it is the cell-sized square
one cell ahead of the robot along its heading (the sensing box of its observation).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from maopg.tasks.box_pushing.config import Config
from maopg.tasks.box_pushing_grid.world import DIRECTIONS, Layout

BOX_WIDTH = 0.8
"""Cells: a small box's side and the big box's depth (north-south): a robot in the next
column passes it with 0.6 cell between the box and its centre."""
BIG_BOX_LENGTH = 1.8
"""Cells: the big box's east-west length (it covers two cells, as on the grid)."""
BOX_HEIGHT = 0.3
"""m: above a robot's bumper, below its camera (0.35 m on the Turtlebot), so the camera sees
a box it stands in front of, top and face."""
BOX_SIDE_FRICTION = 0.05
"""A box's sliding friction against robots, walls and boxes: a bumper pushing low on a box
wedges it to the floor (the box leans forward about its front edge; the bumper, which holds its
height, presses down), adding up to this times the push to the box's load (``scene.py``)."""


def yaw_of(heading: int) -> float:
    """The yaw (rad) of a compass heading (0..3 = N, E, S, W)."""
    return math.pi / 2 - heading * math.pi / 2


def heading_of(yaw: float) -> int:
    """The compass heading (0..3 = N, E, S, W) nearest to ``yaw``."""
    return round((math.pi / 2 - yaw) / (math.pi / 2)) % 4


@dataclass(frozen=True)
class Arena:
    """The layout of one config, in metres."""

    layout: Layout
    """The grid's, in cells."""
    cell: float
    """Side of a cell (m)."""

    @classmethod
    def of(cls, config: Config) -> Arena:
        return cls(Layout.of(config.size, config.agents), config.cell_size)

    @property
    def size(self) -> int:
        """Cells a side."""
        return self.layout.size

    @property
    def side(self) -> float:
        """The arena's side (m)."""
        return self.size * self.cell

    def metres(self, xy: Sequence[float]) -> tuple[float, float]:
        """A point of the grid (cell units) in metres."""
        return float(xy[0]) * self.cell, float(xy[1]) * self.cell

    @property
    def starts(self) -> tuple[tuple[float, float, float], ...]:
        """Each agent's start ``(x, y, yaw)``."""
        return tuple((*self.metres((x, y)), yaw_of(o)) for x, y, o in self.layout.starts)

    @property
    def boxes(self) -> tuple[tuple[float, float], ...]:
        """Start centres of small box 0, small box 1 and the big box."""
        return tuple(self.metres(xy) for xy in (*self.layout.small_boxes, self.layout.big_box))

    @property
    def waypoints(self) -> tuple[tuple[float, float], ...]:
        """Below small box 0, small box 1, the big box's left half, its right half."""
        return tuple(self.metres(xy) for xy in self.layout.waypoints)

    @property
    def goal_line(self) -> float:
        """The goal strip's southern edge (m): a box whose centre is north of it is delivered."""
        return (self.size - 1) * self.cell

    def cell_of(self, xy: Sequence[float]) -> tuple[int, int]:
        """``(column, row)`` of the cell holding ``xy`` (outside the arena: beyond its range)."""
        return math.floor(xy[0] / self.cell), math.floor(xy[1] / self.cell)

    def centre(self, cell: tuple[int, int]) -> np.ndarray:
        """The centre (m) of cell ``(column, row)``."""
        return (np.asarray(cell, dtype=float) + 0.5) * self.cell

    def inside(self, cell: tuple[int, int]) -> bool:
        return 0 <= cell[0] < self.size and 0 <= cell[1] < self.size

    def front(self, xy: Sequence[float], heading: int) -> np.ndarray:
        """The centre of the sensing box: one cell ahead of ``xy`` along ``heading``."""
        return np.asarray(xy[:2], dtype=float) + self.cell * np.asarray(DIRECTIONS[heading])

    def in_front(self, xy: Sequence[float], heading: int, points: np.ndarray) -> np.ndarray:
        """Which of ``points [N, 2]`` lie in the sensing box ahead of ``xy``."""
        offset = np.abs(np.asarray(points, dtype=float).reshape(-1, 2) - self.front(xy, heading))
        return (offset <= self.cell / 2).all(axis=1)

    def beyond_wall(self, xy: Sequence[float]) -> bool:
        """``xy`` lies outside the walls (the wall bit, for the sensing box's centre)."""
        return not all(0.0 <= v <= self.side for v in xy[:2])
