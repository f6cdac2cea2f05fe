"""The swap-demo robot: a real differential drive (two powered wheels, two ball casters).

Unlike the Turtlebot and the vehicle, whose bases slide on joints, this robot is a free body
moved only by wheel-floor friction, and it cannot strafe. Its adapter still implements the
:class:`~maopg.sim.robots.base.GroundAdapter` API, so a task that drives a Turtlebot or the
vehicle drives this robot unchanged. ``drive_to`` is a heading controller run at
``control_hz``: turn toward the target (in place when it is far off the nose), then roll at
``min(speed, pos_kp * distance)`` scaled by the cosine of the heading error; ``turn_to`` spins
it on the spot with the same heading gain.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco

from maopg.sim.robots.base import GroundAdapter, wrap_angle


@dataclass(frozen=True)
class DiffbotConstants:
    """Geometry, speeds and gains of the differential drive (the one place they are set)."""

    max_speed: float = 0.55  # m/s
    wheel_radius: float = 0.06  # m, must match the MJCF
    track: float = 0.4  # m, distance between the wheel contact points
    #: Wheel velocity-servo gain (N m per rad/s), written into the actuators.
    wheel_kv: float = 2.0
    pos_kp: float = 1.5  # 1/s: forward speed = min(speed, pos_kp * distance)
    heading_kp: float = 4.0  # 1/s: turn rate = heading_kp * heading error
    max_turn_rate: float = 2.5  # rad/s
    #: Turn in place while the target is more than this far off the nose (rad).
    turn_in_place: float = 0.8
    #: Closer than this to the target (m), the wheels stop: no spinning on the spot.
    stop_tol: float = 0.04
    #: Footprint radius (m) for path planning.
    radius: float = 0.23
    #: The wheels' actuators (left, right): their local names in the robot's MJCF.
    wheel_actuators: tuple[str, str] = ("wheel_left", "wheel_right")


class DiffbotAdapter(GroundAdapter):
    """Differential-drive adapter: a heading controller turns commands into wheel speeds."""

    Constants = DiffbotConstants
    control_hz: ClassVar[float | None] = 20.0

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, prefix: str, constants: Any = None
    ) -> None:
        super().__init__(model, data, prefix, constants)
        c = self.constants
        setting = f"{type(c).__name__}.wheel_actuators"
        self._left, self._right = (self.actuator_id(n, setting) for n in c.wheel_actuators)
        for local in c.wheel_actuators:
            self.set_velocity_gain(local, c.wheel_kv)
        # wheel speed limit (rad/s): the wheels' ctrlrange upper bound; without one, none
        self._wheel_max = min(
            float(model.actuator_ctrlrange[a, 1]) if model.actuator_ctrllimited[a] else math.inf
            for a in (self._left, self._right)
        )
        self.reset()

    def reset(self) -> None:
        self._goal: tuple[float, float] | None = None
        self._speed = self.max_speed
        self._vel = (0.0, 0.0)
        self._face: float | None = None
        self.hold()

    def hold(self) -> None:
        pos = self.data.xpos[self.root_body_id]
        self.drive_to((pos[0], pos[1]))

    def drive_to(self, xy: Sequence[float], speed: float | None = None) -> None:
        self._goal, self._face = (float(xy[0]), float(xy[1])), None
        self._speed = self.max_speed if speed is None else min(float(speed), self.max_speed)

    def set_velocity(self, vx: float, vy: float) -> None:
        """Turn toward the commanded direction and roll at its magnitude (capped)."""
        self._goal, self._face = None, None
        self._vel = (float(vx), float(vy))

    def turn_to(self, yaw: float) -> None:
        """Spin on the spot (no forward speed) until the heading is ``yaw``."""
        self._goal, self._face = None, float(yaw)

    def apply(self) -> None:
        c = self.constants
        yaw = self.yaw
        if self._face is not None:
            err = wrap_angle(self._face - yaw)
            self._set_wheels(0.0, max(-c.max_turn_rate, min(c.max_turn_rate, c.heading_kp * err)))
            return
        if self._goal is not None:
            pos = self.data.xpos[self.root_body_id]
            dx, dy = self._goal[0] - pos[0], self._goal[1] - pos[1]
            dist = math.hypot(dx, dy)
            speed = min(self._speed, c.pos_kp * dist)
            if dist < c.stop_tol:
                speed = 0.0
        else:
            dx, dy = self._vel
            speed = min(math.hypot(dx, dy), self.max_speed)
        if speed <= 0.0:
            self._set_wheels(0.0, 0.0)
            return
        err = wrap_angle(math.atan2(dy, dx) - yaw)
        turn = max(-c.max_turn_rate, min(c.max_turn_rate, c.heading_kp * err))
        forward = 0.0 if abs(err) > c.turn_in_place else speed * math.cos(err)
        self._set_wheels(forward, turn)

    def _set_wheels(self, forward: float, turn: float) -> None:
        """Unicycle (v, w) -> wheel angular velocities, clipped to the actuator range."""
        c = self.constants
        half = 0.5 * c.track * turn
        lim = self._wheel_max
        ctrl = self.data.ctrl
        ctrl[self._left] = max(-lim, min(lim, (forward - half) / c.wheel_radius))
        ctrl[self._right] = max(-lim, min(lim, (forward + half) / c.wheel_radius))
