"""A task's robot settings take robots of the role the task gives them: another is refused
in one line, naming the setting and the robots allowed there, before anything is built or
written."""

from __future__ import annotations

import math

import pytest

from maopg.env.rollout import evaluate_reference
from maopg.experiment.cli.train_cli import main as train_main
from maopg.sim.robots import robots_of_role

CASES = [
    ("tool_delivery", "turtlebot_robot", "drone", "is a drone robot", "ground"),
    ("tool_delivery", "fetch_robot", "diffbot", "is a ground robot", "arm"),
    ("water_filling", "drone_robot", "turtlebot", "is a ground robot", "drone"),
    ("water_filling", "vehicle_robot", "drone", "is a drone robot", "ground"),
    ("box_pushing", "turtlebot_robot", "nosuch", "unknown robot", "ground"),
]


@pytest.mark.parametrize(("task", "setting", "robot", "plays", "role"), CASES)
def test_a_robot_of_another_role_is_refused_before_anything_is_written(
    task: str, setting: str, robot: str, plays: str, role: str, tmp_path, monkeypatch, capsys
) -> None:
    monkeypatch.chdir(tmp_path)
    assert train_main(["--task", task, f"env.{setting}={robot}"]) == 2
    allowed = ", ".join(robots_of_role(role))
    what = f"unknown robot {robot!r}" if plays == "unknown robot" else f"{robot!r} {plays}"
    assert capsys.readouterr().err == (
        f"python -m train: error: env.{setting}: {what}; allowed: {allowed}\n"
    )
    assert not list(tmp_path.iterdir())


def test_the_robots_allowed_are_those_playing_the_role() -> None:
    assert {"diffbot", "turtlebot", "vehicle"} <= set(robots_of_role("ground"))
    assert "drone" in robots_of_role("drone") and "fetch" in robots_of_role("arm")
    assert not {"drone", "fetch"} & set(robots_of_role("ground"))


@pytest.mark.parametrize(
    ("task", "setting"), [("tool_delivery", "turtlebot_robot"), ("water_filling", "vehicle_robot")]
)
@pytest.mark.parametrize("robot", robots_of_role("ground"))
def test_every_ground_robot_drives_a_tasks_ground_agents(task: str, setting: str, robot: str):
    """Each registered robot of the ground role builds in the task's ground seats and plays
    scripted episodes there (Water Filling plans its vehicle's paths with the robot's footprint:
    measured from its geoms where its constants give no radius) — or, in Tool Delivery's
    Turtlebot seats, which carry tools in a basket, is refused in one line when it has none."""
    overrides = {setting: robot, "max_ticks": 12}
    if task == "tool_delivery" and robot == "vehicle":
        with pytest.raises(ValueError, match=r"^env\.turtlebot_robot: 'vehicle' has no 'basket'"):
            evaluate_reference(task, "scripted", 1, seed=0, overrides=overrides)
        return
    (result,) = evaluate_reference(task, "scripted", 1, seed=0, overrides=overrides)
    assert result.ticks > 0 and math.isfinite(result.ret)
