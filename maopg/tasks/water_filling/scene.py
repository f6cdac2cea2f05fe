"""The Water Filling room: where its jars and spawn points are, and the compiled scene.

The arena MJCF marks jar stands and spawn points with sites and sizes the floor to the room, so
the task and its scripted policy read the layout from the same file instead of repeating it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from maopg.sim.assets import ASSETS_DIR
from maopg.sim.props import arena_floor, layout_sites
from maopg.sim.scene import Scene, SceneBuilder
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import AGENTS, DRONE, NUM_JARS, VEHICLE

JAR_PROP = ASSETS_DIR / "props" / "jar.xml"


@dataclass(frozen=True)
class Arena:
    """The room of one config: jar stands, robot starts and the floor's half extent (m)."""

    jar_sites: tuple[np.ndarray, ...]
    """World position of each jar's stand site."""
    starts: tuple[tuple[float, float], tuple[float, float]]
    """Planar starts of the vehicle and the drone."""
    half_extent: tuple[float, float]

    @property
    def jar_xy(self) -> np.ndarray:
        """``(NUM_JARS, 2)`` planar jar positions."""
        return np.array([site[:2] for site in self.jar_sites])


def arena_path(config: Config) -> Path:
    return ASSETS_DIR / config.arena


def read_arena(config: Config) -> Arena:
    """The arena of ``config``, with its spawn sites unless the config sets the starts (which
    must lie on the floor: ``ValueError`` naming the setting)."""
    path = arena_path(config)
    sites = layout_sites(path)
    floor = arena_floor(path)
    for setting, start in (
        ("vehicle_start", config.vehicle_start),
        ("drone_start", config.drone_start),
    ):
        if start is not None:
            floor.require_inside(f"env.{setting}", start)
    return Arena(
        jar_sites=tuple(sites[f"jar_{c}"] for c in range(NUM_JARS)),
        starts=(
            config.vehicle_start or _planar(sites["spawn_vehicle"]),
            config.drone_start or _planar(sites["spawn_drone"]),
        ),
        half_extent=floor.half_extent,
    )


def _planar(site: np.ndarray) -> tuple[float, float]:
    return float(site[0]), float(site[1])


def build_scene(config: Config, arena: Arena) -> Scene:
    """Compile the room with the jars on their stands and both robots at their starts."""
    builder = SceneBuilder(
        arena_path(config), timestep=config.timestep, render_size=config.image_size
    )
    for c, site in enumerate(arena.jar_sites):
        builder.add_prop(f"jar{c}", JAR_PROP, site)
    builder.add_robot(AGENTS[VEHICLE], config.vehicle_robot, (*arena.starts[VEHICLE], 0.0))
    builder.add_robot(AGENTS[DRONE], config.drone_robot, (*arena.starts[DRONE], 0.0))
    return builder.build()
