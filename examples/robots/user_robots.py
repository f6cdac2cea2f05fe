"""A user's robots, outside the package: a quadrotor and a holonomic base, as collections ship them.

``quadrotor.xml`` is a Skydio-X2-style quadrotor (four ``<motor>`` thrust actuators on sites),
``holonomic_base.xml`` a mobile base on slide/hinge joints with ``<position>`` actuators. Neither
needs code of its own: maopg's quadrotor controller and planar-base controller are configured
by constants, and the subclasses below only name the root body and the camera. Importing this
module registers both, so any command line can use them (docs/tutorial_robot.md)::

    python -m eval check-robot --import examples.robots.user_robots --robot holonomic_base
    python -m eval check-robot --import examples.robots.user_robots --robot quadrotor
    python -m eval evaluate --import examples.robots.user_robots --reference scripted \\
        --task water_filling env.drone_robot=quadrotor env.vehicle_robot=holonomic_base
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from maopg.sim.robots import PlanarBaseConstants, PlanarGroundAdapter, register_robot
from maopg.sim.robots.drone import DroneAdapter, DroneConstants

HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class HolonomicBaseConstants(PlanarBaseConstants):
    """The base's names as its file has them, and gains for the tasks' timesteps.

    The adapter writes these gains into the file's ``<position>`` actuators (the slides become
    velocity servos, the hinge a PD servo). A stiff heading gain without the damping to match
    (``yaw_kp=1e5, yaw_kv=10``) makes MuJoCo reset the physics at Tool Delivery's 20 ms step:
    ``check-robot`` says so, and an episode with it ends truncated with a physics warning.
    """

    max_speed: float = 0.6  # m/s: a Turtlebot's, 0.6 m per Tool Delivery tick
    #: Slide velocity servo (N per m/s): time constant 15 kg / 1500 = 10 ms.
    kv: float = 1500.0
    #: Heading PD (N m per rad, N m per rad/s): about critically damped for 0.55 kg m^2.
    yaw_kp: float = 40.0
    yaw_kv: float = 9.0
    joints: tuple[str, str, str] = ("joint_x", "joint_y", "joint_th")
    actuators: tuple[str, str, str] = ("joint_x", "joint_y", "joint_th")
    #: Footprint radius (m) for Water Filling's planner: the chassis's half-diagonal.
    radius: float = 0.32


class HolonomicBaseAdapter(PlanarGroundAdapter):
    """maopg's planar-base controller on this file's root body and camera."""

    Constants = HolonomicBaseConstants
    root_body = "base_link"
    camera = "base_cam"


QUADROTOR = DroneConstants(rotors=("thrust1", "thrust2", "thrust3", "thrust4"))
"""maopg's quadrotor gains, with this file's rotor actuators; the mixer, mass and inertia
come from the compiled model."""


class QuadrotorAdapter(DroneAdapter):
    """maopg's cascaded quadrotor controller on this file's root body and camera."""

    root_body = "x2"
    camera = "fpv"


register_robot("quadrotor", HERE / "quadrotor.xml", QuadrotorAdapter, QUADROTOR)
register_robot("holonomic_base", HERE / "holonomic_base.xml", HolonomicBaseAdapter)
