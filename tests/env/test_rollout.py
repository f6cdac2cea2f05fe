"""Reference policies come from the task's registry entry, built from the task's config."""

from __future__ import annotations

import pytest

from maopg.env import make_env
from maopg.env.panel import panel_items
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.tasks import register_task, registry
from maopg.tasks.tool_delivery.task import ToolDelivery


class PlainDelivery(ToolDelivery):
    """Tool Delivery registered by a user under a name of its own, with nothing but the class."""

    name = "plain_delivery"


@pytest.fixture
def plain_delivery(monkeypatch):
    monkeypatch.setattr(registry, "_TASKS", dict(registry._TASKS))
    register_task(PlainDelivery.name, PlainDelivery)
    env = make_env(PlainDelivery.name, overrides={"max_ticks": 10})
    yield env
    env.close()


def test_a_task_without_a_scripted_policy_says_so_and_random_still_works(plain_delivery) -> None:
    env = plain_delivery
    with pytest.raises(ValueError, match="task 'plain_delivery' has no scripted policy"):
        reference_policy("scripted", env)
    result = run_episode(env, reference_policy("random", env, seed=2), seed=0)
    assert result.ticks == 10
    # and its video panel falls back to the generic state lines
    assert panel_items(env.spec.task, {"human_stage": 0}) == ["human stage: 0"]


def test_the_scripted_policy_follows_the_env_config() -> None:
    env = make_env("tool_delivery", overrides={"max_ticks": 10})
    try:
        policy = reference_policy("scripted", env)
        point = env.reset()
        joint = policy(point)
        names = [env.spec.agents[i].option_names[o] for i, o in enumerate(joint)]
        assert names == ["GetTool", "GetTool", "SearchTool(0)"]
        assert isinstance(reference_policy("random", env, 1), RandomPolicy)
        with pytest.raises(ValueError, match="unknown reference policy 'greedy'"):
            reference_policy("greedy", env)
    finally:
        env.close()
    primitive = make_env("tool_delivery", "primitive")
    try:
        with pytest.raises(ValueError, match="drives options, not primitive actions"):
            reference_policy("scripted", primitive)
    finally:
        primitive.close()
