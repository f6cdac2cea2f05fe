"""Watching the physics inside a tick (:meth:`Scene.watch_substeps`, what a video films between
ticks) leaves the trajectory bit for bit as it is, on real tasks."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy


def _trajectory(task: str, frames: int | None) -> tuple[list[dict], list[np.ndarray]]:
    """Every tick's physical state of a random episode, and the positions the watcher saw."""
    env = make_env(task, "continue", seed=0, overrides={"max_ticks": 12})
    scene = env.task.scene
    states: list[dict] = []
    seen: list[np.ndarray] = []
    env.add_tick_listener(lambda _env, _reward: states.append(scene.state()))
    if frames is not None:
        scene.watch_substeps(frames, lambda: seen.append(scene.data.xpos.copy()))
    policy = RandomPolicy(env.spec, 3)
    try:
        point = env.reset(seed=3)
        while not point.done:
            point = env.step(policy(point))
    finally:
        env.close()
    return states, seen


# Tool Delivery: one mj_step call a tick; Water Filling: the drone's 50 Hz controller steps it
# in chunks, some marks fall inside one
@pytest.mark.parametrize("task", ["tool_delivery", "water_filling"])
def test_watching_the_substeps_changes_no_state(task: str) -> None:
    plain, _ = _trajectory(task, None)
    watched, seen = _trajectory(task, 4)
    assert len(plain) == len(watched) == 12
    for a, b in zip(plain, watched, strict=True):
        for key in ("qpos", "qvel", "act"):
            assert np.array_equal(a[key], b[key]), key
        assert a["time"] == b["time"]
    assert len(seen) == 3 * 12  # three inside each tick; the fourth is the tick's end
    # the watcher sees fresh positions: the robots move from one call to the next
    moved = [not np.array_equal(a, b) for a, b in itertools.pairwise(seen)]
    assert sum(moved) > len(moved) / 2


def test_the_marks_are_evenly_spaced_and_none_past_the_advance() -> None:
    env = make_env("tool_delivery", "continue", seed=0)
    scene = env.task.scene
    times: list[float] = []
    try:
        scene.watch_substeps(4, lambda: times.append(scene.data.time))
        start = scene.data.time
        scene.advance(1.0)  # 50 steps of 20 ms
        scene.watch_substeps(1, None)
        scene.advance(1.0)
    finally:
        env.close()
    assert np.allclose(np.array(times) - start, [0.24, 0.5, 0.76])  # steps 12, 25, 38
    with pytest.raises(ValueError, match="frames must be at least 1"):
        scene.watch_substeps(0, lambda: None)
