"""Turtlebot: the tool-delivery robot (holonomic planar base + basket + onboard camera)."""

from __future__ import annotations

from dataclasses import dataclass

from maopg.sim.robots.base import PlanarBaseConstants, PlanarGroundAdapter


@dataclass(frozen=True)
class TurtlebotConstants(PlanarBaseConstants):
    """Speeds and servo gains: the one place to tune the Turtlebot's low-level controller."""

    #: The canonical task moves a Turtlebot 0.6 m per 1-s tick.
    max_speed: float = 0.6
    #: Velocity-servo gain of the x/y slides (N per m/s): time constant mass / kv = 10 ms, so a
    #: 1-s tick loses only ~6 mm to acceleration.
    kv: float = 300.0
    #: Heading PD gains (N m per rad, N m per rad/s): about critically damped for the base.
    yaw_kp: float = 8.0
    yaw_kv: float = 1.5


class TurtlebotAdapter(PlanarGroundAdapter):
    """Binds a Turtlebot; the basket body (``<prefix>/basket``) is where tools are welded."""

    Constants = TurtlebotConstants
    basket: str = "basket"

    @property
    def basket_body(self) -> str:
        """Full name of the body a carried tool is welded to."""
        return self.name(self.basket)
