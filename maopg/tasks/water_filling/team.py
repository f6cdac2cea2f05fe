"""Who plays a Water Filling episode, and how many copies of the room they need.

The team is ``vehicles`` ground vehicles and ``drones`` drones keeping ``jars`` jars filled
(config settings; 1, 1 and 3 by default: the paper's task). Agents are the vehicles, then the
drones; a kind with one robot keeps the plain name (``vehicle``, ``drone``: the default team's
names), several are numbered (``vehicle0``, ``vehicle1``, ...).

The room grows with the team so that its density stays the default room's: the arena has
``stands`` jar stands and ``spawns`` spawn points per room, and the team gets the fewest rooms
that seat every jar and every robot, tiled (:mod:`maopg.sim.tiling`) in a near-square grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from maopg.tasks.water_filling.config import Config

VEHICLE_NAME, DRONE_NAME = "vehicle", "drone"


def _names(kind: str, count: int) -> tuple[str, ...]:
    return (kind,) if count == 1 else tuple(f"{kind}{k}" for k in range(count))


@dataclass(frozen=True)
class Team:
    """The team of one config (build with :meth:`of`, which checks the settings)."""

    vehicles: int
    drones: int
    jars: int

    @classmethod
    def of(cls, config: Config) -> Team:
        """The team of ``config`` (whose fields checked their own bounds); a ``ValueError``
        names a start setting that cannot be played with it."""
        for key, count in (("vehicle_start", config.vehicles), ("drone_start", config.drones)):
            if getattr(config, key) is not None and count > 1:
                kind = key.removesuffix("_start")
                raise ValueError(
                    f"{key} sets the start of the only {kind}; with {kind}s={count} they start "
                    "at the room's spawn points: leave it unset"
                )
        return cls(config.vehicles, config.drones, config.jars)

    @property
    def size(self) -> int:
        """Number of agents."""
        return self.vehicles + self.drones

    @property
    def names(self) -> tuple[str, ...]:
        """Agent names, vehicles first."""
        return (*_names(VEHICLE_NAME, self.vehicles), *_names(DRONE_NAME, self.drones))

    def is_drone(self, agent: int) -> bool:
        return agent >= self.vehicles

    def robot(self, config: Config, agent: int) -> str:
        """Registry name of the robot agent ``agent`` drives."""
        return config.drone_robot if self.is_drone(agent) else config.vehicle_robot

    @property
    def drone_agents(self) -> range:
        return range(self.vehicles, self.size)

    def tiles(self, stands: int, spawns: int) -> tuple[int, int]:
        """``(cols, rows)`` of rooms: the fewest that seat the jars on ``stands`` stands and the
        robots on ``spawns`` spawn points per room, as square as possible (2 -> 2 x 1,
        3 -> 3 x 1, 4 -> 2 x 2, 5 -> 3 x 2)."""
        rooms = max(math.ceil(self.jars / stands), math.ceil(self.size / spawns))
        rows = math.isqrt(rooms)
        return math.ceil(rooms / rows), rows
