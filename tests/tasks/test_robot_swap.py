"""Swapping a robot: a differently built ground robot replaces the Turtlebots, no code changes."""

from __future__ import annotations

import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.rollout import reference_policy, run_episode
from maopg.sim import robots
from maopg.sim.robots import get_robot, register_robot
from maopg.sim.robots.fetch import FetchAdapter
from maopg.tasks.tool_delivery.config import Config

GO_WS_AND_WAIT = ("GoToWS", "GoToWS", "Wait")
GET_TOOL_WAIT = ("GetTool", "GetTool", "Wait")


def test_diffbot_replaces_the_turtlebots_through_the_task_config() -> None:
    env = make_env("tool_delivery", overrides={"turtlebot_robot": "diffbot"})
    assert env.spec.agents[0].robot == "diffbot"
    robot = env.task.turtlebots[0]
    assert type(robot).__name__ == "DiffbotAdapter"
    start = robot.position
    result = run_episode(env, reference_policy("scripted", env))
    # A slower, turning differential drive still completes the task with the same policy.
    assert result.solved and result.ret > 150
    assert np.linalg.norm(robot.position[:2] - start[:2]) > 1.0
    env.close()


def test_a_robot_registered_from_a_file_is_used_by_name(monkeypatch) -> None:
    # A private copy of the registry, so the new name does not outlive this test.
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    diffbot = get_robot("diffbot")
    register_robot("my_ground_robot", diffbot.mjcf, diffbot.adapter, diffbot.constants)
    env = make_env("tool_delivery", overrides={"turtlebot_robot": "my_ground_robot"})
    point = env.reset()
    while point.ticks < 8:  # both drive toward the workshop, the Fetch waits
        joint = [env.spec.agents[i].option_index(o) for i, o in enumerate(GO_WS_AND_WAIT)]
        point = env.step(np.where(point.choosing, joint, point.running))
    assert env.spec.agents[1].robot == "my_ground_robot"
    assert env.task.turtlebots[1].position[0] > 3.2
    env.close()


def test_the_eval_cli_swaps_robots_by_config(capsys) -> None:
    from maopg.experiment.cli.eval_cli import main

    argv = ["evaluate", "--reference", "scripted", "--episodes", "1"]
    assert main([*argv, "env.turtlebot_robot=diffbot"]) == 0
    out = capsys.readouterr().out
    assert "| scripted | tool_delivery | continue | 1 |" in out and "| 100% |" in out


def test_an_arm_with_its_own_gripper_body_takes_the_fetch_role(tmp_path, monkeypatch) -> None:
    """The body tools are welded to is the arm adapter's ``gripper``, not a task constant."""
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    fetch = get_robot("fetch")
    text = fetch.mjcf.read_text()
    assert text.count('<body name="gripper"') == 1
    (tmp_path / "arm.xml").write_text(text.replace('<body name="gripper"', '<body name="hand"'))

    class HandArm(FetchAdapter):
        gripper = "hand"

    register_robot("hand_arm", tmp_path / "arm.xml", HandArm, fetch.constants)
    env = make_env("tool_delivery", overrides={"fetch_robot": "hand_arm"})
    assert env.task.fetch.gripper_body == "fetch/hand"
    result = run_episode(env, reference_policy("scripted", env))
    assert result.solved and result.ret == 259.0  # the Fetch's own scripted return
    env.close()
    with pytest.raises(
        ValueError, match=r"env.fetch_robot: 'diffbot' is a ground robot; allowed: "
    ):
        make_env("tool_delivery", overrides={"fetch_robot": "diffbot"})


def test_the_arm_base_and_the_desk_spots_are_task_settings() -> None:
    defaults = Config()
    assert defaults.fetch_base == (0.9, 1.8)
    assert defaults.desk_spots == ((0.8, 3.0), (1.2, 3.0))
    spots = ((0.8, 2.9), (1.2, 2.9))
    env = make_env("tool_delivery", overrides={"fetch_base": (0.95, 1.8), "desk_spots": spots})
    np.testing.assert_allclose(env.task.fetch.position[:2], (0.95, 1.8))
    point = env.reset()
    get_tool_and_wait = [
        a.option_index(o) for a, o in zip(env.spec.agents, GET_TOOL_WAIT, strict=True)
    ]
    while point.ticks < 8:
        point = env.step(np.where(point.choosing, get_tool_and_wait, point.running))
    for w, robot in enumerate(env.task.turtlebots):
        assert robot.at(spots[w], 0.01), f"turtlebot{w} waits at {robot.position[:2]}"
    result = run_episode(env, reference_policy("scripted", env))
    assert result.solved  # the arm, moved, reaches the shelf, the desk and both baskets
    env.close()
