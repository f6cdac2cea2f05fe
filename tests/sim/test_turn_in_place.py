"""``GroundAdapter.turn_to``: every ground robot that implements it turns on the spot to a
heading and keeps it; one that does not refuses in one line."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from maopg.sim.checks import compose
from maopg.sim.robots import GroundAdapter, get_robot, robot_names
from maopg.sim.robots.base import wrap_angle

GROUND = [n for n in robot_names() if issubclass(get_robot(n).adapter_class(), GroundAdapter)]
TURN = 2.0  # rad: well past a quarter turn, both ways round tested
SECONDS = 2.0
YAW_TOL = 0.05  # rad
DRIFT_TOL = 0.1
"""m: a differential drive turns about its axle, off the origin of its base (the diffbot's
lies 4 cm ahead: a 2 rad turn moves the origin 7 cm)."""
TIMESTEP = 0.01
"""Box Pushing's physics step, the task that turns robots on the spot (at 20 ms the
diffbot's force-limited wheel servos rock it about the heading)."""


@pytest.mark.parametrize("name", GROUND)
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_ground_robot_turns_in_place_and_keeps_the_heading(name: str, sign: float) -> None:
    scene = compose(get_robot(name), timestep=TIMESTEP)
    robot = scene.robots["robot"]
    start = robot.position
    goal = wrap_angle(robot.yaw + sign * TURN)
    robot.turn_to(goal)
    scene.advance(SECONDS)
    assert abs(wrap_angle(robot.yaw - goal)) < YAW_TOL
    robot.hold()  # holding after a turn keeps the heading
    scene.advance(SECONDS)
    assert abs(wrap_angle(robot.yaw - goal)) < YAW_TOL
    assert math.dist(robot.position[:2], start[:2]) < DRIFT_TOL


def test_a_drive_without_turn_to_refuses() -> None:
    """The default, which a user's drive that only rolls to points inherits."""
    drive = SimpleNamespace(prefix="r")
    with pytest.raises(NotImplementedError, match=r"robot 'r' \(SimpleNamespace\) cannot turn"):
        GroundAdapter.turn_to(drive, 0.0)  # type: ignore[arg-type]
