"""Scenes shared by the simulation-core tests."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from maopg.sim.scene import Scene, SceneBuilder

TD_TIMESTEP = 0.02
TD_HOLDERS = (None, "fetch/gripper", "tb0/basket", "tb1/basket")


def build_td_scene(tb0=(3.0, 1.5), tb1=(3.0, 2.5)) -> Scene:
    """The Tool Delivery scene as the task composes it (docs/DESIGN.md §7)."""
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=TD_TIMESTEP)
    builder.add_robot("fetch", "fetch", (0.9, 1.8, 0.0))
    builder.add_robot("tb0", "turtlebot", (*tb0, 0.0))
    builder.add_robot("tb1", "turtlebot", (*tb1, 0.0))
    for i in range(3):
        builder.add_attachable(f"tool{i}/tool", TD_HOLDERS)
    return builder.build()


@pytest.fixture
def td_scene() -> Callable[..., Scene]:
    """Factory for the Tool Delivery scene (Turtlebot start positions as arguments)."""
    return build_td_scene
