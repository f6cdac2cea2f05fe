"""The differential-drive adapter on a file of its own names: its wheel actuators are a
setting, and a name it cannot find is refused with the names the file has."""

from __future__ import annotations

# isort: off
import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
# isort: on

import pytest

from maopg.sim import robots
from maopg.sim.checks import check_robot, compose, format_report
from maopg.sim.robots import ASSETS_DIR, get_robot, register_robot
from maopg.sim.robots.diffbot import DiffbotAdapter, DiffbotConstants

WHEELS = ("wheel_left_joint_velocity", "wheel_right_joint_velocity")
"""Actuator names as a mobile base's description might have them (a TIAGo's, say)."""


@pytest.fixture
def base_file(tmp_path, monkeypatch):
    """The shipped differential drive with its wheel actuators renamed to :data:`WHEELS` and
    without a ``ctrlrange`` (unlimited wheel speed), in a private copy of the registry."""
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    text = (ASSETS_DIR / "robots" / "diffbot.xml").read_text()
    for side, name in zip(("left", "right"), WHEELS, strict=True):
        old = f'<velocity name="wheel_{side}" joint="wheel_{side}" kv="2" ctrlrange="-15 15"'
        assert old in text
        text = text.replace(old, f'<velocity name="{name}" joint="wheel_{side}" kv="2"')
    path = tmp_path / "base.xml"
    path.write_text(text)
    return path


def test_wheel_actuators_of_other_names_are_a_setting(base_file) -> None:
    register_robot("base", base_file, DiffbotAdapter, DiffbotConstants(wheel_actuators=WHEELS))
    results = check_robot("base", "ground")
    assert all(r.passed for r in results), format_report("base", "ground", results)


def test_wheel_actuators_it_cannot_find_are_refused_with_the_names_the_file_has(
    base_file,
) -> None:
    register_robot("base", base_file, DiffbotAdapter)
    message = (
        "DiffbotAdapter for 'robot': the model has no actuator 'robot/wheel_left'; the robot's "
        f"actuators: {', '.join(WHEELS)}; set DiffbotConstants.wheel_actuators to one of them"
    )
    with pytest.raises(KeyError) as refused:
        compose(get_robot("base"), 0.02)
    assert refused.value.args == (message,)
