"""Water Filling's config, in a module of its own: the registry reads its defaults and
validates overrides without importing the simulation."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

from maopg.settings import setting
from maopg.tasks.config import SceneTaskConfig


@dataclass(frozen=True)
class Config(SceneTaskConfig):
    """Water Filling settings (docs/DESIGN.md §7 defaults)."""

    max_ticks: int = 300
    tick_seconds: float = 0.5
    timestep: float = 0.005
    """Physics step (s); the drone's 50 Hz controller runs every 4 steps (tuned for <= 5 ms)."""
    arena: str = "arenas/water_filling.xml"
    """The room's MJCF, relative to the package's assets folder (its jar stands and spawn
    sites included)."""
    # Team size (maopg.tasks.water_filling.team): the room is tiled from ``arena`` to fit them;
    # ``vehicle_start`` / ``drone_start`` apply only to a team with one vehicle / one drone.
    vehicles: int = setting(1, ge=1)
    """Ground vehicles (agents ``vehicle``, or ``vehicle0``.. when several); at least 1."""
    drones: int = setting(1, ge=1)
    """Drones (agents ``drone``, or ``drone0``.. when several); at least 1."""
    jars: int = setting(3, ge=1)
    """Jars to keep filled; at least 1."""
    ROBOT_ROLES: ClassVar[Mapping[str, str]] = {"vehicle_robot": "ground", "drone_robot": "drone"}
    vehicle_robot: str = "vehicle"
    """The registered robot that plays the ground vehicles."""
    drone_robot: str = "drone"
    """The registered robot that plays the drones."""
    vehicle_start: tuple[float, float] | None = None
    """Planar start of the vehicle (default: the arena's ``spawn_vehicle`` site)."""
    drone_start: tuple[float, float] | None = None
    """Planar start of the drone (default: ``spawn_drone``); it starts hovering at cruise."""
    cruise_altitude: float = setting(1.5, gt=0.0)
    """Height the drones fly and plan their paths at (m), over the furniture."""
    interval_scale: tuple[int, int] = setting((5, 15), ge=1, increasing=True)
    """Exponential scale of a jar's drop interval: ``rng.integers(low, high)`` ticks."""
    drop_mean_per_tick: float = setting(1.0 / 500.0, ge=0.0)
    """Mean level a jar loses per tick of its interval: a drop is
    ``|N(interval x drop_mean_per_tick, drop_std)|`` (:mod:`maopg.tasks.water_filling.water`)."""
    drop_std: float = setting(0.2, ge=0.0)
    """Standard deviation of a drop of a jar's level."""
    fill_radius: float = setting(1.0, gt=0.0)
    """A vehicle fills a jar within this planar distance of it (m)."""
    observe_radius: float = setting(1.0, gt=0.0)
    """A jar within this distance of any robot has its level observed by the team (m)."""
    reward_eps: float = setting(0.001, gt=0.0)
    """ε of the reward ``sum_c (1 - 1 / (w_c + ε))`` over the jars' levels (paper Eq. 6)."""
    grid_resolution: float = setting(0.1, gt=0.0)
    """Cell side of the occupancy grids that NavTo plans its paths on (m)."""
    vehicle_reach: float = setting(0.8, gt=0.0)
    """NavTo of the vehicle ends at the first free cell within this distance of the jar (m)."""
    drone_standoff: float = setting(0.75, gt=0.0)
    """NavTo of the drone ends hovering this close to the jar (m), facing it."""
    drone_radius: float = setting(0.3, ge=0.0)
    """Drone footprint radius for its cruise-level planning grid (m)."""
    vehicle_arrive_tol: float = setting(0.05, gt=0.0)
    """A vehicle within this distance of a waypoint has arrived (m)."""
    drone_arrive_tol: float = setting(0.15, gt=0.0)
    """A drone within this distance of a waypoint has arrived (m)."""
    face_tol: float = setting(0.35, gt=0.0)
    """NavTo ends facing the jar within this angle (rad), so the camera shows its level."""
    nav_slack_ticks: int = setting(8, ge=0)
    """NavTo gives up after the path's travel time at full speed plus this many ticks."""
