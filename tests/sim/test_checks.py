"""The robot checks (``check-robot``): they fail the broken robots a task would fail quietly."""

from __future__ import annotations

import re

import pytest

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.sim import robots
from maopg.sim.checks import check_robot, format_report
from maopg.sim.robots import ASSETS_DIR, register_robot
from maopg.sim.robots.diffbot import DiffbotConstants
from maopg.sim.robots.turtlebot import TurtlebotConstants

DRONE_XML = ASSETS_DIR / "robots" / "drone.xml"
TURTLEBOT_XML = ASSETS_DIR / "robots" / "turtlebot.xml"
DIFFBOT_XML = ASSETS_DIR / "robots" / "diffbot.xml"
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
    # can give at hover), but cannot turn it: the report says which bound of the cap to raise
    problems = failed(check_robot(drone_with_drag(tmp_path, "0.0002"), "drone"))
    assert list(problems) == ["yaw"]
    assert "is yaw_share's: DroneConstants: raise yaw_share (now 0.5)" in problems["yaw"]
    assert "drag torques (gear[5])" in problems["yaw"]


def test_a_ground_robot_whose_physics_mujoco_resets_fails(tmp_path, monkeypatch, registry) -> None:
    results = check_robot(stiff_turtlebot(tmp_path, monkeypatch), "ground")
    problems = failed(results)
    assert "mjWARN_BADQACC" in problems["stable"] and "robot/yaw" in problems["stable"]
    assert problems["reach 1"] == "physics went unstable"
    assert {"reach 2", "heading", "hold"} <= set(problems)


def test_wheel_servos_too_stiff_for_the_step_fail_stable_though_mujoco_warns_of_nothing(
    registry,
) -> None:
    """Stiff wheel servos at Tool Delivery's 20 ms step rock the robot about where it should
    stand, with no physics warning: ``stable`` measures that drift and says what to lower."""
    adapter = "maopg.sim.robots.diffbot:DiffbotAdapter"
    register_robot("stiff_wheels", DIFFBOT_XML, adapter, DiffbotConstants(wheel_kv=20.0))
    results = {r.name: r for r in check_robot("stiff_wheels", "ground")}
    stable = results["stable"]
    assert not stable.passed and stable.measured > 0.1 and stable.threshold == 0.02
    assert stable.detail == (
        "drift holding still 3 s, no physics warning; it wanders instead of settling: a servo "
        "too stiff for the 0.02 s timestep; DiffbotConstants: lower wheel_kv (now 20), or the "
        "timestep"
    )
    assert results["hold"].detail.endswith("lower wheel_kv (now 20), or the timestep")


def test_a_servo_too_weak_to_stop_the_robot_is_told_to_be_raised(registry) -> None:
    adapter = "maopg.sim.robots.turtlebot:TurtlebotAdapter"
    register_robot("weak", TURTLEBOT_XML, adapter, TurtlebotConstants(kv=1.0))
    problems = failed(check_robot("weak", "ground"))
    assert list(problems) == ["reach 1", "reach 2", "hold", "stable"]
    assert problems["reach 1"].endswith("; TurtlebotConstants: raise kv (now 1)")
    assert problems["stable"].endswith(
        "still coming to a stop: its servos are too weak; TurtlebotConstants: raise kv (now 1)"
    )


def test_an_element_the_adapter_cannot_find_fails_compose_with_the_names_the_file_has(
    registry,
) -> None:
    register_robot("wheelless", TURTLEBOT_XML, "maopg.sim.robots.diffbot:DiffbotAdapter")
    assert failed(check_robot("wheelless", "ground")) == {
        "compose": "KeyError: DiffbotAdapter for 'robot': the model has no actuator "
        "'robot/wheel_left'; the robot's actuators: vx, vy, yaw; set "
        "DiffbotConstants.wheel_actuators to one of them"
    }


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
    assert failed(results) == {
        "role": "TurtlebotAdapter is not a DroneAdapter: check it as --role ground"
    }
    assert "FAILED: role" in format_report("turtlebot", "drone", results)
