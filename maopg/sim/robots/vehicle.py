"""Water Filling's ground vehicle: a slow holonomic base with a water tank and a filler arm.

The drivetrain is the shared :class:`~maopg.sim.robots.base.PlanarGroundAdapter` (slide x/y
velocity servos + yaw PD servo); only the constants differ from the Turtlebot: the vehicle is
heavier (40 kg) and slower (0.5 m/s, docs/DESIGN.md §7), and it can fill a jar within
``fill_radius``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from maopg.sim.robots.base import PlanarBaseConstants, PlanarGroundAdapter


@dataclass(frozen=True)
class VehicleConstants(PlanarBaseConstants):
    """Speeds and servo gains of the vehicle (the one place they are set)."""

    max_speed: float = 0.5  # m/s (docs/DESIGN.md §7: the slow robot)
    #: Velocity-servo gain of each slide (N per m/s). With 40 kg: 0.1 s time constant.
    kv: float = 400.0
    #: Yaw PD servo (N m per rad, N m per rad/s); yaw inertia 2.2 kg m^2 -> ~0.8 damping ratio.
    yaw_kp: float = 40.0
    yaw_kv: float = 15.0
    #: Footprint radius (m) for path planning: the collision box's half-diagonal.
    radius: float = 0.36
    #: A jar within this planar distance (m) of the base can be filled (docs/DESIGN.md §7).
    fill_radius: float = 1.0


class VehicleAdapter(PlanarGroundAdapter):
    """Planar vehicle driven like the Turtlebot; exposes its filler nozzle for tasks."""

    Constants = VehicleConstants

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, prefix: str, constants: Any = None
    ) -> None:
        super().__init__(model, data, prefix, constants)
        self._filler_site = self.object_id(mujoco.mjtObj.mjOBJ_SITE, "filler_tip")

    @property
    def filler_tip(self) -> np.ndarray:
        """World position (3,) of the filler nozzle tip (a copy)."""
        return self.data.site_xpos[self._filler_site].copy()
