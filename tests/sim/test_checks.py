"""The robot checks (``check-robot``): they fail the broken robots a task would fail quietly."""

from __future__ import annotations

import re

import pytest

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.sim import robots
from maopg.sim.checks import check_robot, format_report
from maopg.sim.robots import ASSETS_DIR, register_robot
from maopg.sim.robots.turtlebot import TurtlebotConstants

DRONE_XML = ASSETS_DIR / "robots" / "drone.xml"
TURTLEBOT_XML = ASSETS_DIR / "robots" / "turtlebot.xml"
STIFF = TurtlebotConstants(yaw_kp=1e5, yaw_kv=0.0)
"""A heading servo far too stiff for Tool Delivery's 20 ms step: MuJoCo resets the physics."""


@pytest.fixture
def registry(monkeypatch) -> None:
    """A private copy of the robot registry, so test robots do not outlive the test."""
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))


def drone_with_drag(tmp_path, drag: str) -> str:
    """The shipped quadrotor with rotor drag torques ``drag`` (N m per N) instead of 0.016."""
    text, rotors = re.subn(
        r'gear="0 0 1 0 0 (-?)0\.016"', rf'gear="0 0 1 0 0 \g<1>{drag}"', DRONE_XML.read_text()
    )
    assert rotors == 4
    path = tmp_path / f"drone_drag_{drag}.xml"
    path.write_text(text)
    name = f"drone_drag_{drag}"
    register_robot(name, path, "maopg.sim.robots.drone:DroneAdapter")
    return name


def stiff_turtlebot(tmp_path, monkeypatch) -> str:
    """Registers a Turtlebot with :data:`STIFF` gains (MuJoCo logs the instability it causes to
    ``MUJOCO_LOG.TXT`` in the working directory, so the test runs in ``tmp_path``)."""
    monkeypatch.chdir(tmp_path)
    register_robot("stiff", TURTLEBOT_XML, "maopg.sim.robots.turtlebot:TurtlebotAdapter", STIFF)
    return "stiff"


def failed(results) -> dict[str, str]:
    return {r.name: r.detail for r in results if not r.passed}


def test_a_drone_that_cannot_yaw_fails(tmp_path, registry) -> None:
    results = check_robot(drone_with_drag(tmp_path, "0"), "drone")
    assert list(failed(results)) == ["compose"]
    assert "cannot produce yaw torque" in failed(results)["compose"]
    # rotors with almost no drag torque bind and fly (the yaw torque cap keeps within what they
    # can give at hover), but cannot turn it
    problems = failed(check_robot(drone_with_drag(tmp_path, "0.0002"), "drone"))
    assert list(problems) == ["yaw"]


def test_a_ground_robot_whose_physics_mujoco_resets_fails(tmp_path, monkeypatch, registry) -> None:
    results = check_robot(stiff_turtlebot(tmp_path, monkeypatch), "ground")
    problems = failed(results)
    assert "mjWARN_BADQACC" in problems["stable"] and "robot/yaw" in problems["stable"]
    assert problems["reach 1"] == "physics went unstable"
    assert {"reach 2", "heading", "hold"} <= set(problems)


def test_check_robot_command_prints_figures_and_sets_the_exit_status(
    capsys, tmp_path, monkeypatch, registry
) -> None:
    assert eval_main(["check-robot", "--robot", "turtlebot", "--role", "ground"]) == 0
    out = capsys.readouterr().out
    assert "robot 'turtlebot' as ground:" in out and out.rstrip().endswith("all checks passed")
    assert "PASS  reach 1" in out and "(<= 0.2)" in out  # the heading threshold
    assert eval_main(["check-robot", "--robot", stiff_turtlebot(tmp_path, monkeypatch)]) == 1
    assert "FAILED: reach 1, reach 2, heading, hold, stable" in capsys.readouterr().out


def test_a_robot_checked_in_a_role_its_adapter_does_not_play_fails() -> None:
    results = check_robot("turtlebot", "drone")
    assert failed(results) == {"role": "TurtlebotAdapter is not a DroneAdapter"}
    assert "FAILED: role" in format_report("turtlebot", "drone", results)
