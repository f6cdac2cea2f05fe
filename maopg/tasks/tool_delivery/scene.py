"""The Tool Delivery scene: the warehouse arena, the Turtlebots, the Fetches and the tools.

One builder for the task and for the simulation tests, so both exercise the same composition.
The canonical team (one Fetch, one human) uses ``assets/arenas/tool_delivery.xml`` as it is;
a larger team grows that arena with ``MjSpec`` (:func:`grow_arena`): a mirrored second bay, a
shelf with three tools per further human, a human per further workshop (layout in
:mod:`~maopg.tasks.tool_delivery.team`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from maopg.sim.assets import ASSETS_DIR
from maopg.sim.props import arena_floor
from maopg.sim.robots import get_robot, robots_of_role
from maopg.sim.scene import Scene, SceneBuilder, load_spec
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import BASKET, NUM_TOOLS, TOOL
from maopg.tasks.tool_delivery.team import (
    BAY_HEIGHT,
    HUMAN_OFFSET,
    SHELF_TOP,
    SLOT_SPACING,
    TOOL_FILES,
    Team,
)

ARENA = ASSETS_DIR / "arenas" / "tool_delivery.xml"
PROPS = ASSETS_DIR / "props"
OVERVIEW_BACKOFF = 1.6
"""How much farther the overview camera backs off (same direction, same field of view) to keep
the two-bay world in view: doubling the distance for twice the length leaves half the frame
empty, since the tilted view's footprint grows faster than the distance."""


def gripper_body(config: Config, fetch: str) -> str:
    """The scene name of the body the arm welds a grasped tool to (its adapter says which)."""
    arm = get_robot(config.fetch_robot).adapter_class()  # an ArmAdapter: the config checks it
    return f"{fetch}/{arm.gripper}"


def grow_arena(builder: SceneBuilder, team: Team) -> None:
    """Add what a team beyond the canonical one needs to the canonical arena.

    Two Fetches: the world doubles along y (floor, walls, the tool room's floor and its
    partition mirrored, the overview camera backed off by ``OVERVIEW_BACKOFF``) and bay 1's desk
    is added. Every further human gets a shelf with its three tools and a
    workbench at its workshop.
    """
    spec, height = builder.spec, team.height
    if team.fetches > 1:
        scale = height / BAY_HEIGHT
        spec.geom("floor").pos[1] = height / 2
        spec.geom("floor").size[1] = height / 2
        spec.material("floor").texrepeat[1] *= scale
        spec.geom("tool_room_floor").pos[1] = height / 2
        spec.geom("tool_room_floor").size[1] = height / 2
        spec.material("room").texrepeat[1] *= scale
        spec.geom("wall_n").pos[1] = height + 0.05
        for side in ("wall_w", "wall_e"):
            spec.geom(side).pos[1] = height / 2
            spec.geom(side).size[1] = height / 2
        south = spec.geom("partition_s")
        spec.geom("partition_n").pos = [south.pos[0], height - south.pos[1], south.pos[2]]
        spec.geom("partition_n").size = south.size
        camera = spec.camera("overview")
        centre = np.array([3.5, BAY_HEIGHT / 2, 0.0])
        camera.pos = [3.5, height / 2, 0.0] + (np.asarray(camera.pos) - centre) * OVERVIEW_BACKOFF
        for f in team.fetch_ids[1:]:
            builder.add_prop(team.desk(f), PROPS / "desk.xml", (*team.desk_center(f), 0.0))
    for h in range(1, team.humans):
        (x, y), yaw = team.shelf_pose(h)
        builder.add_prop(team.shelf(h), PROPS / "shelf.xml", (x, y, 0.0), yaw)
        wx, wy = team.workshops[h]
        builder.add_prop(team.human(h), PROPS / "human.xml", (wx + HUMAN_OFFSET, wy, 0.0))
        for j in range(NUM_TOOLS):
            offset = (j - 1) * SLOT_SPACING
            slot = (x - offset * math.sin(yaw), y + offset * math.cos(yaw), SHELF_TOP)
            builder.add_prop(f"tool{team.tool(h, j)}", PROPS / TOOL_FILES[j], slot, yaw)


def _lacks_a_basket(spec: mujoco.MjSpec, prefix: str = "") -> list[str]:
    """What of a tool carrier's parts the robot under ``prefix`` in ``spec`` lacks: the
    ``basket`` body tools are welded to and the ``load`` site a Fetch puts them down at."""
    parts = {
        "a 'basket' body": spec.body(f"{prefix}basket"),
        "a 'load' site": spec.site(f"{prefix}load"),
    }
    return [part for part, found in parts.items() if found is None]


def require_carrier(builder: SceneBuilder, name: str, robot: str) -> None:
    """Refuse, in one line before the scene compiles, a Turtlebot seat ``name`` whose robot
    cannot carry tools, naming the ground robots that can (their files read only then)."""
    missing = _lacks_a_basket(builder.spec, f"{name}/")
    if missing:
        able = [
            r for r in robots_of_role("ground") if not _lacks_a_basket(load_spec(get_robot(r).mjcf))
        ]
        raise ValueError(
            f"env.turtlebot_robot: {robot!r} has no {' and no '.join(m[2:] for m in missing)}"
            f" (a Turtlebot seat carries tools in its basket); robots that can: {', '.join(able)}"
        )


def build_scene(config: Config, turtlebot_starts: Sequence[tuple[float, float]] = ()) -> Scene:
    """Compile the scene (Turtlebots at the team's starts unless given); each tool may rest in
    the world, in any Fetch's gripper or in any Turtlebot's basket."""
    team = Team.of(config)
    floor = arena_floor(ARENA)  # the settings place bay 0's arm and desk spots
    floor.require_inside("env.fetch_base", config.fetch_base)
    for w, spot in enumerate(config.desk_spots):
        floor.require_inside(f"env.desk_spots[{w}]", spot)
    builder = SceneBuilder(
        ARENA,
        timestep=config.timestep,
        render_size=config.image_size,
        appearance=config.appearance,
    )
    if not team.canonical_arena:
        grow_arena(builder, team)
    turtlebots, fetches = team.agents[: team.turtlebots], team.agents[team.turtlebots :]
    for name, (x, y) in zip(turtlebots, turtlebot_starts or team.starts, strict=True):
        builder.add_robot(name, config.turtlebot_robot, (x, y, 0.0), yaw=math.pi)
        require_carrier(builder, name, config.turtlebot_robot)
    for name, (x, y) in zip(fetches, team.fetch_bases, strict=True):
        builder.add_robot(name, config.fetch_robot, (x, y, 0.0), yaw=0.0)
    holders = [
        None,
        *(gripper_body(config, name) for name in fetches),
        *(BASKET.format(name) for name in turtlebots),
    ]
    for t in range(team.num_tools):
        builder.add_attachable(TOOL.format(t), holders)
    return builder.build()
