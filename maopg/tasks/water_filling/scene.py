"""The Water Filling room: where its jars and spawn points are, and the compiled scene.

The arena MJCF marks jar stands and spawn points with sites and sizes the floor to the room, so
the task and its scripted policy read the layout from the same file instead of repeating it.

A team that does not fit one room (more jars than stands, more robots than spawn points: see
:mod:`~maopg.tasks.water_filling.team`) plays in a room tiled from copies of the arena
(:func:`maopg.sim.tiling.tile_arena`). Jar ``j`` then stands in tile ``j mod T`` (``T`` tiles) on
stand ``(j div T + tile) mod S`` (``S`` stands per tile), so jars spread over every tile first
and neighbouring tiles use different corners; agent ``a`` starts in tile ``a mod T`` at spawn
point ``a div T`` (``spawn_vehicle``, then ``spawn_drone``), so every tile gets a robot before
any gets two. With one tile this is the arena's own layout: jar ``c`` on stand ``jar_c``, the
vehicle at ``spawn_vehicle``, the drone at ``spawn_drone``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from maopg.sim.assets import ASSETS_DIR
from maopg.sim.props import arena_floor, layout_sites
from maopg.sim.scene import Scene, SceneBuilder
from maopg.sim.tiling import tile_arena, tile_prefix
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.team import Team

JAR_PROP = ASSETS_DIR / "props" / "jar.xml"
SPAWNS = ("spawn_vehicle", "spawn_drone")
"""The spawn sites of one room, in the order agents take them."""
STAND = "jar_"
"""Prefix of the jar stand sites (``jar_0``, ``jar_1``, ...)."""


@dataclass(frozen=True)
class Arena:
    """The room of one config: jar stands, robot starts and the floor's half extent (m)."""

    jar_sites: tuple[np.ndarray, ...]
    """World position of each jar's stand site."""
    starts: tuple[tuple[float, float], ...]
    """Planar start of each agent (the default team: the vehicle's, then the drone's)."""
    half_extent: tuple[float, float]
    tiles: tuple[int, int] = (1, 1)
    """``(cols, rows)`` copies of the arena file the room is made of."""

    @property
    def jar_xy(self) -> np.ndarray:
        """``(jars, 2)`` planar jar positions."""
        return np.array([site[:2] for site in self.jar_sites])


def arena_path(config: Config) -> Path:
    return ASSETS_DIR / config.arena


def arena_source(config: Config, tiles: tuple[int, int]) -> Path | mujoco.MjSpec:
    """The arena file itself for one tile, else the tiled room's spec."""
    path = arena_path(config)
    return path if tiles == (1, 1) else tile_arena(path, *tiles)


def read_arena(config: Config) -> Arena:
    """The arena of ``config``, with its spawn sites unless the config sets the starts (checks
    the team settings: :meth:`Team.of`)."""
    team = Team.of(config)
    path = arena_path(config)
    sites = layout_sites(path)
    stands = sum(name.startswith(STAND) for name in sites)
    if stands == 0:
        raise ValueError(f"arena {config.arena} has no jar stand sites ({STAND}0, ...)")
    tiles = team.tiles(stands, len(SPAWNS))
    count = tiles[0] * tiles[1]
    model = tile_arena(path, *tiles).compile() if count > 1 else None
    if model is not None:
        sites = layout_sites(model)
    floor = arena_floor(model if model is not None else path)
    for setting, start in (
        ("vehicle_start", config.vehicle_start),
        ("drone_start", config.drone_start),
    ):
        if start is not None:
            floor.require_inside(f"env.{setting}", start)

    def site(tile: int, name: str) -> np.ndarray:
        return sites[(tile_prefix(tile) if count > 1 else "") + name]

    jar_sites = tuple(
        site(j % count, f"{STAND}{(j // count + j % count) % stands}") for j in range(team.jars)
    )
    starts = [_planar(site(a % count, SPAWNS[a // count])) for a in range(team.size)]
    if config.vehicle_start is not None:  # Team.of: only with one vehicle
        starts[0] = config.vehicle_start
    if config.drone_start is not None:  # only with one drone, the last agent
        starts[-1] = config.drone_start
    return Arena(
        jar_sites=jar_sites,
        starts=tuple(starts),
        half_extent=floor.half_extent,
        tiles=tiles,
    )


def _planar(site: np.ndarray) -> tuple[float, float]:
    return float(site[0]), float(site[1])


def build_scene(config: Config, arena: Arena) -> Scene:
    """Compile the room with the jars on their stands and every robot at its start."""
    builder = SceneBuilder(
        arena_source(config, arena.tiles),
        timestep=config.timestep,
        render_size=config.image_size,
        appearance=config.appearance,
    )
    for c, site in enumerate(arena.jar_sites):
        builder.add_prop(f"jar{c}", JAR_PROP, site)
    team = Team.of(config)
    for agent, (name, start) in enumerate(zip(team.names, arena.starts, strict=True)):
        builder.add_robot(name, team.robot(config, agent), (*start, 0.0))
    return builder.build()
