"""Names and fixed facts of Water Filling (docs/DESIGN.md §7); the room itself is read from the
arena MJCF (:mod:`maopg.tasks.water_filling.scene`)."""

from __future__ import annotations

from maopg.options.moves import EAST, NORTH, SOUTH, WEST
from maopg.tasks.layout import ObsLayout
from maopg.tasks.water_filling.config import Config

VEHICLE, DRONE = 0, 1
"""Agent indices in the default team (one vehicle, one drone; vehicles always come first)."""
NUM_JARS = Config.jars
"""Jars of the default task."""

#: Compass moves in the top view, as both robots name them: Up = north (+y), Right = east (+x).
MOVES = (("Up", NORTH), ("Down", SOUTH), ("Left", WEST), ("Right", EAST))
FILL_NEAREST = "Fill"
"""The primitive Fill: the nearest jar in reach."""


def fill(jar: int) -> str:
    return f"Fill({jar})"


def nav_to(jar: int) -> str:
    return f"NavTo({jar})"


def nav_to_fill(jar: int) -> str:
    return f"NavToFill({jar})"


def obs_layout(jars: int) -> ObsLayout:
    """Every robot's observation vector with ``jars`` jars: the shared knowledge plus where the
    robot is."""
    return ObsLayout.of(
        known_levels=jars,  # last level any robot saw, per jar
        elapsed=jars,  # ticks since each was seen, divided by max_ticks
        position=2,  # own planar position divided by the room's half extent
    )


OBS = obs_layout(NUM_JARS)
"""The default task's observation vector."""

FACE_CREEP = 0.04
"""How far (m) the vehicle creeps toward a jar per tick to turn its heading onto it."""
GROUND_BAND = (0.02, 0.8)
"""Height band (m) of the floor-level obstacles the vehicle plans around."""
