"""The contract every registered task meets: build, reset, spaces, a random episode under every
strategy, determinism, a scripted policy if it declares one, camera images, and video labels
inside the overview.

Parametrised over the registry, so a newly registered task is covered without a line here;
``SETTINGS`` adds runs of a task at other settings than its defaults (a scaled team).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from maopg.env import Strategy, make_env
from maopg.env.panel import panel_items
from maopg.env.pettingzoo import OptionParallelEnv
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.env.video import OVERVIEW_SIZE
from maopg.sim.framing import overview_view
from maopg.tasks import SceneTask, Task, TaskConfig, task_entry, task_names
from maopg.tasks.panel import Field, Gauge, Heading

TASKS = task_names()
MAX_TICKS = 60
"""Short episodes: the contract is about shapes and invariants, not about solving the task."""
SETTINGS: dict[str, list[dict]] = {
    "tool_delivery": [
        {"turtlebots": 6, "fetches": 2, "humans": 3},
        {"turtlebots": 6, "fetches": 2, "humans": 3, "mask_options": True},
    ],
    "water_filling": [
        {"vehicles": 2, "drones": 1, "jars": 4},
        {"vehicles": 4, "drones": 4, "jars": 8},
    ],
}
"""Task settings the contract runs at besides each task's defaults: scaled teams, among them
the teams of eight of the ``teams`` study at its settings."""
CASES = [pytest.param(task, {}, id=task) for task in TASKS] + [
    pytest.param(task, s, id=f"{task}[{','.join(f'{k}={v}' for k, v in s.items())}]")
    for task, settings in SETTINGS.items()
    for s in settings
]


def short_env(task: str, strategy: str = "continue", settings: dict | None = None, **kwargs):
    overrides = {"max_ticks": MAX_TICKS, **(settings or {})}
    return make_env(task, strategy, overrides=overrides, **kwargs)


@pytest.mark.parametrize("task", TASKS)
def test_the_entry_resolves_to_the_task_and_its_config(task: str) -> None:
    entry = task_entry(task)
    cls = entry.task_class()
    assert issubclass(cls, Task) and issubclass(entry.config_class(), TaskConfig)
    assert cls.name == task, "rollouts and videos find the entry by the task's name"


@pytest.mark.parametrize(("task", "settings"), CASES)
def test_spec_spaces_and_the_reset_point_agree(task: str, settings: dict) -> None:
    env = short_env(task, settings=settings)
    try:
        spec, point = env.spec, env.reset(seed=0)
        assert spec.task == task and spec.num_agents == len(env.task.agent_names) >= 1
        assert spec.image_shape is None and point.images is None
        for i, agent in enumerate(spec.agents):
            assert agent.layout is not None and agent.layout.size == agent.vector_size
            assert len(set(agent.option_names)) == agent.num_options >= 1, "names are unique"
            assert all(agent.option_index(n) == k for k, n in enumerate(agent.option_names))
            vector = point.vectors[i]
            assert vector.shape == (agent.vector_size,) and vector.dtype == np.float32
            assert np.isfinite(vector).all()
            mask = point.available[i]
            assert mask.shape == (agent.num_options,) and mask.dtype == bool and mask.any()
        assert point.choosing.all() and (point.running == -1).all()
        assert point.duration == 0 and point.ticks == 0 and not point.done
        # a global state, where the task's settings declare one, of the length its spec says
        assert (spec.state_size is not None) == type(env.task.config).HAS_STATE
        if spec.state_size is None:
            assert point.state is None
        else:
            assert point.state.shape == (spec.state_size,) and point.state.dtype == np.float32
        parallel = OptionParallelEnv(env)
        observations, _ = parallel.reset(seed=0)
        for name, obs in observations.items():
            assert parallel.observation_space(name).contains(obs), name
        items = panel_items(task, env.task.describe())
        assert items and all(isinstance(item, str | Heading | Field | Gauge) for item in items)
        if isinstance(env.task, SceneTask):  # a video labels these on its overview
            labels = env.task.labels()
            names = [text for text, _ in labels[: spec.num_agents]]
            assert names == list(env.task.agent_names), "the robots come first"
            scene = env.task.scene
            points = np.array([xyz for _, xyz in labels])
            view = overview_view(scene.model, scene.data, OVERVIEW_SIZE[1] / OVERVIEW_SIZE[0])
            pixels = view.project(points, *OVERVIEW_SIZE)
            assert ((pixels >= 0) & (pixels < OVERVIEW_SIZE[::-1])).all(), "all in the picture"
    finally:
        env.close()


@pytest.mark.parametrize("strategy", [s.value for s in Strategy])
@pytest.mark.parametrize(("task", "settings"), CASES)
def test_a_random_episode_keeps_the_contract(task: str, settings: dict, strategy: str) -> None:
    if strategy not in task_entry(task).task_class().supported_strategies():
        pytest.skip(f"task {task!r} does not declare strategy {strategy!r}")
    env = short_env(task, strategy, settings)
    seen = []
    try:
        result = run_episode(env, RandomPolicy(env.spec, 0), seed=0, on_step=seen.append)
    finally:
        env.close()
    last = seen[-1]
    assert last.done and seen[0].ticks == 0 and not any(p.done for p in seen[:-1])
    assert result.ticks == last.ticks <= MAX_TICKS and not (last.terminated and last.truncated)
    assert last.terminated or last.ticks == MAX_TICKS
    for prev, point in itertools.pairwise(seen):
        assert point.duration >= 1 and point.ticks == prev.ticks + point.duration
        assert np.isfinite(point.reward) and np.isfinite(point.discounted_reward)
        assert point.done or point.choosing.any()
        for vector, agent in zip(point.vectors, env.spec.agents, strict=True):
            assert vector.shape == (agent.vector_size,) and np.isfinite(vector).all()
        if env.spec.state_size is not None:
            assert point.state.shape == (env.spec.state_size,) and np.isfinite(point.state).all()
        if strategy == "primitive":
            assert point.duration == 1
        if strategy in ("any", "all", "primitive") and not point.done:
            assert point.choosing.all()
    assert sum(result.rewards) == pytest.approx(result.ret)


@pytest.mark.parametrize(("task", "settings"), CASES)
def test_the_same_seed_gives_the_same_trajectory(task: str, settings: dict) -> None:
    def trajectory() -> list[tuple]:
        env = short_env(task, "any", settings)
        points = []
        try:
            run_episode(env, RandomPolicy(env.spec, 3), seed=7, on_step=points.append)
        finally:
            env.close()
        return [
            (p.reward, p.ticks, p.running.tobytes(), *(v.tobytes() for v in p.vectors))
            for p in points
        ]

    assert trajectory() == trajectory()


@pytest.mark.parametrize(("task", "settings"), CASES)
def test_a_declared_scripted_policy_plays_options_and_refuses_primitives(
    task: str, settings: dict
) -> None:
    factory = task_entry(task).scripted_factory()
    if factory is None:
        pytest.skip(f"{task} declares no scripted policy")
    env = short_env(task, settings=settings)
    try:
        result = run_episode(env, reference_policy("scripted", env), seed=0)
        assert result.ticks <= MAX_TICKS and result.decisions >= 1
        with pytest.raises(ValueError, match="primitive"):
            factory(task_entry(task).config_class()(primitive=True, **settings))
    finally:
        env.close()


@pytest.mark.parametrize(("task", "settings"), CASES)
def test_cameras_give_non_constant_images(task: str, settings: dict) -> None:
    if not issubclass(task_entry(task).task_class(), SceneTask):
        pytest.skip(f"{task} has no scene to render")
    env = short_env(task, settings=settings, images=True, image_size=32)
    try:
        point = env.reset(seed=0)
        n = env.spec.num_agents
        assert env.spec.image_shape == (32, 32, 3)
        assert point.images.shape == (n, 32, 32, 3) and point.images.dtype == np.uint8
        for i, name in enumerate(env.spec.agent_names):
            assert point.images[i].std() > 1.0, f"{name}'s camera image is flat"
    finally:
        env.close()
