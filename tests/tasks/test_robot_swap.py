"""Swapping a robot: a differently built ground robot replaces the Turtlebots, no code changes."""

from __future__ import annotations

import numpy as np

from maopg.env import make_env
from maopg.env.rollout import reference_policy, run_episode
from maopg.sim import robots
from maopg.sim.robots import get_robot, register_robot

GO_WS_AND_WAIT = ("GoToWS", "GoToWS", "Wait")


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
    from maopg.experiment.eval_cli import main

    argv = ["evaluate", "--reference", "scripted", "--episodes", "1"]
    main([*argv, "--set", "turtlebot_robot=diffbot"])
    out = capsys.readouterr().out
    assert "| scripted | tool_delivery | continue | 1 |" in out and "| 100% |" in out
