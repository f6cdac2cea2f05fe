"""The robots of docs/tutorial_robot.md, used as a user would: ``examples/robots/user_robots.py``
imported from the repository as a module of its own (it registers a Skydio-style quadrotor and
a holonomic base with ``<position>`` actuators), then swapped into both tasks by setting."""

from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.rollout import reference_policy, run_episode
from maopg.sim import robots
from maopg.sim.checks import check_robot, format_report
from maopg.sim.robots import DroneAdapter

REPO = Path(__file__).resolve().parents[2]
MODULE = "examples.robots.user_robots"


@pytest.fixture
def user_robots(monkeypatch) -> ModuleType:
    """Import the example module afresh into a private copy of the robot registry."""
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    monkeypatch.syspath_prepend(str(REPO))
    monkeypatch.delitem(sys.modules, MODULE, raising=False)
    return importlib.import_module(MODULE)


@pytest.mark.parametrize(("name", "role"), [("quadrotor", "drone"), ("holonomic_base", "ground")])
def test_the_example_robots_pass_check_robot(user_robots, name: str, role: str) -> None:
    results = check_robot(name, role)
    assert all(r.passed for r in results), format_report(name, role, results)


def test_the_quadrotor_and_the_base_keep_the_jars_filled(user_robots, monkeypatch) -> None:
    overrides = {"drone_robot": "quadrotor", "vehicle_robot": "holonomic_base", "max_ticks": 40}
    env = make_env("water_filling", images=True, overrides=overrides)
    drone = env.task.drone
    assert type(drone) is user_robots.QuadrotorAdapter
    assert type(env.task.vehicle) is user_robots.HolonomicBaseAdapter
    # Water Filling flies the drone through the documented interface, with headings: an
    # adapter written to DroneAdapter.fly_to's signature takes every call it makes.
    documented, fly_to, yaws = inspect.signature(DroneAdapter.fly_to), drone.fly_to, []

    def checked(*args, **kwargs) -> None:
        yaws.append(documented.bind(drone, *args, **kwargs).arguments.get("yaw"))
        fly_to(*args, **kwargs)

    monkeypatch.setattr(drone, "fly_to", checked)
    starts = [r.position for r in env.task.agent_robots]
    infos, fresh_images = [], []

    def on_step(point) -> None:  # the env reuses its image buffer: copy what is fresh
        infos.append(point.info)
        fresh_images.extend(point.images[i].copy() for i in np.flatnonzero(point.choosing))

    result = run_episode(env, reference_policy("scripted", env), on_step=on_step)
    assert result.ticks == 40 and not any("physics_warning" in info for info in infos)
    assert any(yaw is not None for yaw in yaws), "NavTo turns the drone to face its jar"
    for start, robot in zip(starts, env.task.agent_robots, strict=True):
        assert np.linalg.norm(robot.position[:2] - start[:2]) > 0.5, type(robot).__name__
    assert min(float(image.std()) for image in fresh_images) > 5.0
    env.close()


def test_the_base_takes_the_turtlebots_role_in_tool_delivery(user_robots) -> None:
    env = make_env("tool_delivery", overrides={"turtlebot_robot": "holonomic_base"})
    assert all(type(r) is user_robots.HolonomicBaseAdapter for r in env.task.turtlebots)
    result = run_episode(env, reference_policy("scripted", env))
    assert result.solved and result.ret == 259.0  # as fast as a Turtlebot: the same episode
    env.close()
