"""Scenes shared by the simulation-core tests, built by the tasks' own scene builders."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from maopg.sim.scene import Scene
from maopg.tasks.tool_delivery.config import Config as TDConfig
from maopg.tasks.tool_delivery.constants import TURTLEBOT_STARTS
from maopg.tasks.tool_delivery.scene import build_scene as build_td_scene
from maopg.tasks.water_filling.config import Config as WFConfig
from maopg.tasks.water_filling.scene import build_scene as build_wf_scene
from maopg.tasks.water_filling.scene import read_arena


@pytest.fixture(scope="session")
def td_scene() -> Callable[..., Scene]:
    """Factory for the Tool Delivery scene (Turtlebot start positions as arguments)."""

    def build(tb0=TURTLEBOT_STARTS[0], tb1=TURTLEBOT_STARTS[1]) -> Scene:
        return build_td_scene(TDConfig(), turtlebot_starts=(tb0, tb1))

    return build


@pytest.fixture(scope="session")
def wf_scene() -> Callable[..., Scene]:
    """Factory for the Water Filling scene of a config with overrides (robots, starts)."""

    def build(**overrides) -> Scene:
        config = WFConfig(**overrides)
        return build_wf_scene(config, read_arena(config))

    return build
