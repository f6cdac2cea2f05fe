"""The PettingZoo view's own additions on a real task: the ``parallel_env`` factory, ``state()``,
``render()``, the discounted option reward in the infos, and :func:`decision_point` rebuilding
the very point behind an observation dict — each checked against a twin :class:`OptionEnv`
stepped with the same options from the same seed."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

from maopg.env import make_env
from maopg.env.pettingzoo import OptionParallelEnv, decision_point, parallel_env
from maopg.env.rollout import RandomPolicy

SHORT = {"max_ticks": 30}
"""Short episodes: the view is about shapes and bookkeeping."""


def _twin_episodes(images: bool = False):
    """``(point, observations, infos)`` at every decision point of one random episode, played
    on an ``OptionEnv`` and, with the same options, on the factory's view of its twin."""
    kwargs = {"seed": 0, "images": images, "image_size": 16, "gamma": 0.9, "overrides": SHORT}
    env, view = make_env("tool_delivery", **kwargs), parallel_env("tool_delivery", **kwargs)
    try:
        policy = RandomPolicy(env.spec, seed=2)
        point, (observations, infos) = env.reset(seed=5), view.reset(seed=5)
        states = [view.state()]
        seen = [(copy.deepcopy(point), observations, infos)]  # the env reuses its buffers
        while not point.done:
            joint = policy(point)
            actions = {a: int(o) for a, o in zip(view.agents, joint, strict=True)}
            point = env.step(joint)
            observations, _, _, _, infos = view.step(actions)
            states.append(view.state())
            seen.append((copy.deepcopy(point), observations, infos))
        return seen, states
    finally:
        env.close()
        view.close()


def test_the_factory_builds_a_view_of_the_named_task_and_strategy():
    view = parallel_env("water_filling", "all", seed=0, overrides=SHORT)
    try:
        assert isinstance(view, OptionParallelEnv) and view.possible_agents == ["vehicle", "drone"]
        assert view.env.strategy.value == "all" and view.env.spec.max_ticks == 30
        assert view.metadata["render_modes"] == ["rgb_array"] and view.metadata["is_parallelizable"]
        parallel_api_test(view, num_cycles=40)
    finally:
        view.close()
    with pytest.raises(ValueError, match="render_mode must be None or one of"):
        parallel_env(render_mode="human")


def test_state_infos_and_rebuilt_points_match_the_option_env():
    seen, states = _twin_episodes()
    assert len(seen) > 3 and any(p.duration > 1 for p, _, _ in seen)
    for (point, observations, infos), state in zip(seen, states, strict=True):
        assert state.dtype == np.float32 and state.shape == (33,)
        np.testing.assert_array_equal(state, np.concatenate(point.vectors))
        for info in infos.values():
            assert info["discounted_reward"] == point.discounted_reward
            assert info["duration"] == point.duration and info["ticks"] == point.ticks
        if point.duration > 1 and point.reward != 0:
            assert info["discounted_reward"] != point.reward  # γ = 0.9 discounts it
        rebuilt = decision_point(list(infos), observations, infos)
        for name in ("choosing", "running"):
            np.testing.assert_array_equal(getattr(rebuilt, name), getattr(point, name))
        for got, want in zip(rebuilt.vectors, point.vectors, strict=True):
            np.testing.assert_array_equal(got, want)
        for i in np.flatnonzero(point.choosing):
            np.testing.assert_array_equal(rebuilt.available[i], point.available[i])
        assert (rebuilt.ticks, rebuilt.duration, rebuilt.images) == (
            point.ticks,
            point.duration,
            None,
        )


def test_a_rebuilt_point_carries_the_camera_images():
    seen, _ = _twin_episodes(images=True)
    for point, observations, infos in seen[:3]:
        rebuilt = decision_point(list(infos), observations, infos)
        np.testing.assert_array_equal(rebuilt.images, point.images)


def test_decision_point_names_what_is_missing():
    view = parallel_env(seed=0, overrides=SHORT)
    try:
        observations, infos = view.reset(seed=0)
        with pytest.raises(ValueError, match=r"lack agent\(s\) \['fetch'\]"):
            decision_point(view.possible_agents, {"turtlebot0": {}, "turtlebot1": {}}, infos)
        bare = {agent: {} for agent in infos}
        with pytest.raises(ValueError, match="infos\\['turtlebot0'\\] lacks"):
            decision_point(view.possible_agents, observations, bare)
    finally:
        view.close()


def test_render_draws_the_video_frame_headlessly():
    view = parallel_env(seed=0, render_mode="rgb_array", overrides=SHORT)
    plain = parallel_env(seed=0, overrides=SHORT)
    try:
        with pytest.raises(ValueError, match="render\\(\\) called before reset"):
            view.render()
        view.reset(seed=0)
        first = view.render()
        assert first.dtype == np.uint8 and first.shape == (848, 960, 3)  # the timeline under
        assert first.std() > 10  # a picture, not a blank canvas
        view.step({"turtlebot0": 0, "turtlebot1": 1, "fetch": 2})
        assert np.any(view.render() != first)  # the robots moved, the panel's tick changed
        plain.reset(seed=0)
        with pytest.warns(UserWarning, match="render_mode='rgb_array'"):
            assert plain.render() is None
    finally:
        view.close()
        plain.close()
