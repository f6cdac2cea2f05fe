"""Water Filling's config, in a module of its own: the registry reads its defaults and
validates overrides without importing the simulation."""

from __future__ import annotations

from dataclasses import dataclass

from maopg.tasks.base import TaskConfig


@dataclass(frozen=True)
class Config(TaskConfig):
    """Water Filling settings (docs/DESIGN.md §7 defaults)."""

    max_ticks: int = 300
    tick_seconds: float = 0.5
    timestep: float = 0.005
    """Physics step (s); the drone's 50 Hz controller runs every 4 steps (tuned for <= 5 ms)."""
    arena: str = "arenas/water_filling.xml"
    # Team size (maopg.tasks.water_filling.team): the room is tiled from ``arena`` to fit them;
    # ``vehicle_start`` / ``drone_start`` apply only to a team with one vehicle / one drone.
    vehicles: int = 1
    """Ground vehicles (agents ``vehicle``, or ``vehicle0``.. when several); at least 1."""
    drones: int = 1
    """Drones (agents ``drone``, or ``drone0``.. when several); at least 1."""
    jars: int = 3
    """Jars to keep filled; at least 1."""
    vehicle_robot: str = "vehicle"
    drone_robot: str = "drone"
    vehicle_start: tuple[float, float] | None = None
    """Planar start of the vehicle (default: the arena's ``spawn_vehicle`` site)."""
    drone_start: tuple[float, float] | None = None
    """Planar start of the drone (default: ``spawn_drone``); it starts hovering at cruise."""
    cruise_altitude: float = 1.5
    interval_scale: tuple[int, int] = (5, 15)
    """Exponential scale of a jar's drop interval: ``rng.integers(low, high)`` ticks."""
    drop_mean_per_tick: float = 1.0 / 500.0
    drop_std: float = 0.2
    fill_radius: float = 1.0
    observe_radius: float = 1.0
    reward_eps: float = 0.001
    grid_resolution: float = 0.1
    vehicle_reach: float = 0.8
    """NavTo of the vehicle ends at the first free cell within this distance of the jar (m)."""
    drone_standoff: float = 0.75
    """NavTo of the drone ends hovering this close to the jar (m), facing it."""
    drone_radius: float = 0.3
    """Drone footprint radius for its cruise-level planning grid (m)."""
    vehicle_arrive_tol: float = 0.05
    drone_arrive_tol: float = 0.15
    face_tol: float = 0.35
    """NavTo ends facing the jar within this angle (rad), so the camera shows its level."""
    nav_slack_ticks: int = 8
    """NavTo gives up after the path's travel time at full speed plus this many ticks."""
