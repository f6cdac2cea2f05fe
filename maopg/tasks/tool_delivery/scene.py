"""The Tool Delivery scene: the warehouse arena, two Turtlebots, the Fetch and three tools.

One builder for the task and for the simulation tests, so both exercise the same composition.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from maopg.sim.assets import ASSETS_DIR
from maopg.sim.props import arena_floor
from maopg.sim.robots import ArmAdapter, get_robot
from maopg.sim.scene import Scene, SceneBuilder
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import (
    AGENTS,
    BASKET,
    FETCH,
    NUM_TOOLS,
    TOOL,
    TURTLEBOT_STARTS,
    TURTLEBOTS,
)

ARENA = ASSETS_DIR / "arenas" / "tool_delivery.xml"


def gripper_body(config: Config) -> str:
    """The scene name of the body the arm welds a grasped tool to (its adapter says which)."""
    spec = get_robot(config.fetch_robot)
    arm = spec.adapter_class()
    if not issubclass(arm, ArmAdapter):
        raise ValueError(
            f"fetch_robot={spec.name!r}: Tool Delivery's Fetch must be an arm, and "
            f"{arm.__name__} is not an ArmAdapter"
        )
    return f"{AGENTS[FETCH]}/{arm.gripper}"


def build_scene(
    config: Config, turtlebot_starts: Sequence[tuple[float, float]] = TURTLEBOT_STARTS
) -> Scene:
    """Compile the scene; each tool may rest in the world, the gripper or either basket. The
    positions the config sets must lie on the floor (``ValueError`` naming the setting)."""
    floor = arena_floor(ARENA)
    floor.require_inside("env.fetch_base", config.fetch_base)
    for w, spot in enumerate(config.desk_spots):
        floor.require_inside(f"env.desk_spots[{w}]", spot)
    builder = SceneBuilder(ARENA, timestep=config.timestep, render_size=config.image_size)
    for w, (x, y) in zip(TURTLEBOTS, turtlebot_starts, strict=True):
        builder.add_robot(AGENTS[w], config.turtlebot_robot, (x, y, 0.0), yaw=math.pi)
    builder.add_robot(AGENTS[FETCH], config.fetch_robot, (*config.fetch_base, 0.0), yaw=0.0)
    holders = [None, gripper_body(config), *(BASKET.format(AGENTS[w]) for w in TURTLEBOTS)]
    for j in range(NUM_TOOLS):
        builder.add_attachable(TOOL.format(j), holders)
    return builder.build()
