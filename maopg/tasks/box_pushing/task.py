"""Box Pushing in MuJoCo: the grid benchmark (``box_pushing_grid``) with real robots and boxes.

Two ground robots (three with ``agents=3``; Turtlebots unless ``turtlebot_robot`` names another
ground robot) in a walled arena, the grid scaled by ``cell_size`` (0.6 m: layout in
:mod:`~maopg.tasks.box_pushing.arena`), bring a box to the goal strip along the north wall: a
small one (+20) or the big one (+300); -0.1 per tick, -10 per penalised push; the first
delivery ends the episode (a termination), ``max_ticks`` cuts it (a truncation). ``solved``
means the big box was delivered.

**Cooperation comes from physics.** The boxes are free bodies on the floor, moved only through
contacts with the robots' bumpers. A Turtlebot pushes with at most 180 N (its slide servos'
gain times its top speed); a small box (3 kg) needs 18 N, the big one (47 kg) 277 N, so one
robot cannot move the big box and two can, which ``tests/tasks/test_box_pushing.py`` measures
with the real actuators, with margins both ways (15%: one robot holds a big box 15% lighter
and turns one 17% lighter about a far corner; two deliver one 15% heavier in one push each).
The masses are the Turtlebot's; a robot that pushes harder or softer needs its own, measured
for the built-in ground robots in :data:`~maopg.tasks.box_pushing.config.ROBOT_SETTINGS`.

**Global state**: the grid's 18 floats (24 for three robots), read off the physics
(:meth:`BoxPushing.global_state`), for the critics that take one; no policy reads it.

**The robots' drives.** The benchmark's description speaks of differential-drive robots. This
project's Turtlebot is the paper's: a holonomic planar base whose x/y slides and heading are
servoed (:mod:`maopg.sim.robots.turtlebot`), so its push is bounded by its servos, not by wheel
traction, and it travels to a waypoint in any direction (``Push`` drives it along its heading;
the turns spin it on the spot). It stays the default because it is the robot of the paper's
tasks and covers a grid cell per tick. The built-in differential drive, a free body moved only
by its wheels' friction, is ``turtlebot_robot=diffbot`` with its settings of
:data:`~maopg.tasks.box_pushing.config.ROBOT_SETTINGS`.

Macro-actions (the grid's eight, in its order, each ending on the robot's own physics):

- ``GoToSmallBox(0|1)``, ``GoToBigBox(left|right)``: the shared route navigation
  (:class:`~maopg.options.navigation.NavigateTo`) to the waypoint below that box, around the
  boxes and teammates as they stand (:mod:`~maopg.tasks.box_pushing.routes`); it ends there
  facing north, or after the route's travel time plus ``nav_slack_ticks``.
- ``Push``: drive ahead along the robot's lane (the row or column of its cell, in its compass
  heading). It ends when the robot reaches the last cell before the wall (no penalty), when
  it stalls — less than ``stall_distance`` of progress for ``stall_ticks`` ticks in a row:
  against the big box alone, a box it shoves into a wall, a teammate in the way (penalty) —,
  or at once, penalised, if it starts on the border facing the wall.
- ``TurnLeft``, ``TurnRight``: a quarter turn on the spot; ``Stay``: one tick standing still.

Observation: the grid's 5 bits (small box, big box, empty, wall, teammate) about the cell in
front, computed from the physics state: the cell-sized square one cell ahead of the robot along
its compass heading holds a small box's centre, a centre of one of the big box's two halves,
another robot's centre, or its centre lies beyond the walls. They are refreshed when the
agent's option ends; with ``images`` each robot's RGB camera too.

**Where it differs from the grid, and why** (``tests/tasks/test_box_pushing.py`` pins each):

- Robots collide and block each other; navigation plans around teammates; a push needs
  contact. None of the grid's quirks (walking through teammates and boxes, the joint push read
  from a recorded waypoint, a big-box push that carries its pushers) exist here.
- Durations come from the physics: a GoTo crosses open floor diagonally where the grid walks
  an L and turns (to the big box: 3 / 4 / 4 / 6 ticks on 4x4 / 6x6 / 8x8 / 10x10, the grid
  3 / 4 / 5 / 7), and two Turtlebots push the big box at about 0.14 m/s (a quarter cell a
  tick), so the scripted episode takes 6 / 11 / 15 / 21 ticks (the grid 4 / 6 / 8 / 11).
- A box counts as delivered at the end of the tick in which its centre entered the goal strip
  (the top row of cells), wherever in the strip it then stands; the grid's steps onto the top
  row's centre.
- A lone push into the big box, or a side push of a small box, is penalised when it stalls
  (the grid penalises the first step); a side push moves a small box until then.

The scripted policy is the grid's own (:func:`maopg.tasks.box_pushing_grid.scripted
.scripted_policy`): it reads only option names and the big-box bit, which this task shares,
and chooses the same macro-actions in the same order on every size.

Strategies: all four. ``any`` cuts running options into a hold (a cut Push forgets its stall
count; a cut GoTo plans again when chosen again), ``all`` idles finished robots with a hold,
``primitive`` gives the grid's ``BP-v0`` actions (MoveForward one cell, a quarter turn, Stay;
one tick each; a MoveForward that stalls or faces the wall is penalised).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np

from maopg.options.base import Option
from maopg.sim.planning import Route
from maopg.sim.robots.base import wrap_angle
from maopg.tasks.base import SceneTask
from maopg.tasks.box_pushing.arena import Arena, heading_of, yaw_of
from maopg.tasks.box_pushing.config import Config
from maopg.tasks.box_pushing.options import option_set
from maopg.tasks.box_pushing.routes import Obstacles, plan
from maopg.tasks.box_pushing.scene import BOXES, DELIVERED_RGBA, build_scene
from maopg.tasks.box_pushing_grid.world import (
    BOX_NAMES,
    DIRECTIONS,
    LAYOUT,
    NORTH,
    ORIENTATIONS,
    agent_names,
    state_vector,
)
from maopg.tasks.layout import ObsLayout

NORTH_YAW = yaw_of(NORTH)
PASS_TOL = 0.1
"""m: a route's intermediate corner counts as passed this close (the robot rounds it)."""
SETTLE = 0.25
"""Cells: a robot that reached its waypoint turns north on the spot while within this of it
(a differential drive turns about its axle, which may lie off its origin)."""


@dataclass
class _Push:
    """One robot's running push."""

    direction: np.ndarray
    target: np.ndarray
    """The end of its lane (or its one cell)."""
    last: np.ndarray
    """Its position after the previous tick."""
    one_cell: bool
    into_wall: bool
    """It started on the border facing the wall (it does not move)."""
    stalled: int = 0
    over: bool = False


def footprint(model: mujoco.MjModel, data: mujoco.MjData, root: int) -> float:
    """The planar radius (m) of a robot's collision geoms about its root body."""
    centre = data.xpos[root, :2]
    return max(
        float(np.hypot(*(data.geom_xpos[g, :2] - centre)) + model.geom_rbound[g])
        for g in range(model.ngeom)
        if model.body_rootid[model.geom_bodyid[g]] == root
        and (model.geom_contype[g] or model.geom_conaffinity[g])
    )


class BoxPushing(SceneTask):
    """The arena, its robots and boxes, and the macro-actions' rules (module docstring).

    Implements :class:`~maopg.tasks.box_pushing.options.PushingRules`, the interface its
    options act through.
    """

    name = "box_pushing"
    Config = Config
    prop_classes: ClassVar[Mapping[str, str]] = {
        "small_box": "small_box",
        "big_box": "big_box",
        "goal": "goal",
        "waypoint": "waypoint",
    }
    """Segmentation: the boxes, the goal strip and the GoTo waypoints' markers."""

    def __init__(self, config: Config | None = None) -> None:
        self.config = config = config or Config()
        self.arena = Arena.of(config)
        self.tick_seconds = config.tick_seconds
        self.scene = build_scene(config, self.arena)
        model, data = self.scene.model, self.scene.data
        self.agent_robots = tuple(self.scene.robots[name] for name in self.agent_names)
        self._radius = [footprint(model, data, r.root_body_id) for r in self.agent_robots]
        self._boxes = [model.body(name).id for name in BOXES]
        self._half_sizes = [model.geom(name).size[:2].copy() for name in BOXES]
        self._options = option_set(config)
        self.reset(0)

    # ----------------------------------------------------------------- static description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return agent_names(self.config.agents)

    def robot_of(self, agent: int) -> str:
        return self.config.turtlebot_robot

    def options(self, agent: int) -> Sequence[Option[Any]]:
        return self._options

    def observation_layout(self, agent: int) -> ObsLayout:
        return LAYOUT

    # ----------------------------------------------------------------- dynamics
    @property
    def ticks(self) -> int:
        return self._ticks

    def reset(self, seed: int) -> None:
        # Deterministic, as the grid: the seed is accepted for the contract.
        del seed
        self.scene.reset()
        self._ticks = 0
        self._delivered = [False] * len(BOXES)
        self._pushes: list[_Push | None] = [None] * self.config.agents
        self._settling = [False] * self.config.agents

    def tick(self) -> float:
        c = self.config
        self.scene.advance(c.tick_seconds)
        self._ticks += 1
        reward = c.step_reward
        for i, push in enumerate(self._pushes):
            if push is not None and not push.over:
                reward += self._judge(i, push)
        return reward + self._deliver()

    def terminated(self) -> bool:
        """A box has been delivered (every delivery ends the episode, as on the grid)."""
        return any(self._delivered)

    def solved(self) -> bool:
        """The big box was delivered."""
        return self._delivered[2]

    # ----------------------------------------------------------------- MobileTask, RoutedTask
    def planar_position(self, agent: int) -> tuple[float, float]:
        pos = self.agent_robots[agent].position
        return float(pos[0]), float(pos[1])

    def step_length(self, agent: int) -> float:
        return self.agent_robots[agent].max_speed * self.tick_seconds

    def head_for(self, agent: int, xy: Sequence[float]) -> None:
        self.agent_robots[agent].drive_to(xy)

    def arrived(self, agent: int, xy: Sequence[float]) -> bool:
        return self.agent_robots[agent].at(xy, self.config.arrive_tol)

    def motion_started(self, agent: int) -> None:
        """Nothing to drop: a robot waits for nothing here."""

    def route_to(self, agent: int, goal: int) -> Route:
        """A route to waypoint ``goal`` around the boxes and teammates as they stand now."""
        self._settling[agent] = False
        waypoints = plan(
            self.arena,
            self.planar_position(agent),
            self.arena.waypoints[goal],
            self._obstacles(agent),
            self._radius[agent],
        )
        return Route(waypoints, arrive_tol=self.config.arrive_tol, pass_tol=PASS_TOL)

    def nav_deadline(self, agent: int, route: Route) -> int:
        """The route's travel time at full speed, rounded up, plus ``nav_slack_ticks``."""
        length = route.length_from(self.planar_position(agent))
        return math.ceil(length / self.step_length(agent)) + self.config.nav_slack_ticks

    def follow(self, agent: int, route: Route, goal: int) -> None:
        """Along the route; once at its end, turn north on the spot (within ``SETTLE``)."""
        robot = self.agent_robots[agent]
        self._settling[agent] |= route.last_leg and self.arrived(agent, route.waypoints[-1])
        if self._settled(agent, route):
            robot.turn_to(NORTH_YAW)
        else:
            self._settling[agent] = False
            robot.drive_to(route.target)

    def at_goal(self, agent: int, route: Route, goal: int) -> bool:
        """At the waypoint (within ``arrive_tol``, or settling by it), facing north."""
        self._settling[agent] |= route.update(self.planar_position(agent))
        return self._settled(agent, route) and self.faces(agent, NORTH_YAW)

    def _settled(self, agent: int, route: Route) -> bool:
        """The robot reached the route's end and has stayed within ``SETTLE`` of it."""
        near = math.dist(self.planar_position(agent), route.waypoints[-1])
        return self._settling[agent] and near <= SETTLE * self.arena.cell

    # ----------------------------------------------------------------- PushingRules
    def begin_push(self, agent: int, *, one_cell: bool) -> None:
        arena, pos = self.arena, np.array(self.planar_position(agent))
        heading = self.heading(agent)
        step = np.array(DIRECTIONS[heading], dtype=int)
        cell = np.array(arena.cell_of(arena.front(pos, heading)))
        into_wall = not arena.inside(tuple(cell))
        while not (into_wall or one_cell) and arena.inside(tuple(cell + step)):
            cell += step
        target = pos if into_wall else arena.centre(tuple(cell))
        self._pushes[agent] = _Push(step.astype(float), target, pos, one_cell, into_wall)

    def push_on(self, agent: int) -> None:
        push = self._pushes[agent]
        if push is None or push.into_wall:
            self.hold(agent)
        else:
            self.agent_robots[agent].drive_to(push.target)

    def push_over(self, agent: int) -> bool:
        push = self._pushes[agent]
        return push is None or push.over

    def end_push(self, agent: int) -> None:
        self._pushes[agent] = None

    def heading(self, agent: int) -> int:
        """The compass direction (0..3 = N, E, S, W) the agent's robot faces most nearly."""
        return heading_of(self.agent_robots[agent].yaw)

    def heading_yaw(self, agent: int) -> float:
        return yaw_of(self.heading(agent))

    def turn(self, agent: int, yaw: float) -> None:
        self.agent_robots[agent].turn_to(yaw)

    def faces(self, agent: int, yaw: float) -> bool:
        error = wrap_angle(self.agent_robots[agent].yaw - yaw)
        return abs(error) <= self.config.face_tol

    # ----------------------------------------------------------------- internals
    def _judge(self, agent: int, push: _Push) -> float:
        """The push's outcome after a tick: the penalty it costs, if any (class docstring)."""
        c = self.config
        pos = np.array(self.planar_position(agent))
        progress = float((pos - push.last) @ push.direction)
        push.last = pos
        if push.into_wall:
            push.over = True
            return c.penalty
        if math.dist(pos, push.target) <= c.arrive_tol:
            push.over = True
            return 0.0
        push.stalled = push.stalled + 1 if progress < c.stall_distance else 0
        if push.stalled >= (1 if push.one_cell else c.stall_ticks):
            push.over = True
            return c.penalty
        push.over = push.one_cell
        return 0.0

    def _deliver(self) -> float:
        """Pay for every box whose centre entered the goal strip on this tick (and paint it)."""
        c, xpos = self.config, self.scene.data.xpos
        reward = 0.0
        for k, body in enumerate(self._boxes):
            if not self._delivered[k] and xpos[body, 1] >= self.arena.goal_line:
                self._delivered[k] = True
                reward += c.big_box_reward if k == 2 else c.small_box_reward
                self.scene.set_geom_rgba(BOXES[k], DELIVERED_RGBA)
        return reward

    def _box_poses(self) -> np.ndarray:
        """``[3, 3]``: each box's centre x, y and yaw."""
        data = self.scene.data
        return np.array(
            [(*data.xpos[b, :2], math.atan2(data.xmat[b, 3], data.xmat[b, 0])) for b in self._boxes]
        )

    def _obstacles(self, agent: int) -> Obstacles:
        poses = self._box_poses()
        boxes = np.array(
            [(x, y, *half, yaw) for (x, y, yaw), half in zip(poses, self._half_sizes, strict=True)]
        )
        discs = np.array(
            [
                (*self.planar_position(j), self._radius[j])
                for j in range(self.config.agents)
                if j != agent
            ]
        )
        return Obstacles(boxes, discs)

    # ----------------------------------------------------------------- observations
    def global_state_size(self) -> int:
        """The grid's: per agent its position and a one-hot heading, then the three boxes'."""
        return 6 * len(self.agent_names) + 6

    def global_state(self) -> np.ndarray:
        """The grid's global state read off the physics: per robot its position in cells over
        the side and its heading (the compass direction it faces most nearly) one-hot, then
        each box's centre in cells over the side; at reset, exactly the grid's."""
        cell = self.arena.cell
        positions = [self.planar_position(i) for i in range(len(self.agent_robots))]
        robots = [(x / cell, y / cell, self.heading(i)) for i, (x, y) in enumerate(positions)]
        boxes = [(x / cell, y / cell) for x, y, _ in self._box_poses()]
        return state_vector(robots, boxes, self.arena.size)

    def observe(self, agent: int) -> np.ndarray:
        arena, pos, heading = self.arena, self.planar_position(agent), self.heading(agent)
        poses = self._box_poses()
        centre, yaw = poses[2, :2], poses[2, 2]
        half = arena.cell / 2 * np.array([math.cos(yaw), math.sin(yaw)])
        mates = [self.planar_position(j) for j in range(self.config.agents) if j != agent]
        small = arena.in_front(pos, heading, poses[:2, :2]).any()
        big = arena.in_front(pos, heading, np.array([centre + half, centre - half])).any()
        wall = arena.beyond_wall(arena.front(pos, heading))
        mate = arena.in_front(pos, heading, np.array(mates)).any()
        bits = (small, big, not (small or big or wall or mate), wall, mate)
        return np.array(bits, dtype=np.float32)

    def labels(self) -> list[tuple[str, np.ndarray]]:
        """The robots, and each box by name over its top."""
        xpos = self.scene.data.xpos
        lift = np.array([0.0, 0.0, self.scene.model.geom(BOXES[0]).size[2]])
        boxes = [(name, xpos[b] + lift) for name, b in zip(BOX_NAMES, self._boxes, strict=True)]
        return super().labels() + boxes

    def describe(self) -> dict[str, object]:
        """The state for logs and the video panel, in cells: each robot's ``positions`` and
        ``facing``, the ``boxes``' centres, the big box's cells ``to_goal``, and what has been
        ``delivered``."""
        cell, poses = self.arena.cell, self._box_poses()
        return {
            "size": self.arena.size,
            "cell": cell,
            "positions": [
                (round(x / cell, 2), round(y / cell, 2))
                for x, y in map(self.planar_position, range(self.config.agents))
            ],
            "facing": [ORIENTATIONS[self.heading(i)] for i in range(self.config.agents)],
            "boxes": [(round(float(x) / cell, 2), round(float(y) / cell, 2)) for x, y, _ in poses],
            "to_goal": round(max(0.0, float(self.arena.goal_line - poses[2, 1]) / cell), 2),
            "delivered": [n for n, d in zip(BOX_NAMES, self._delivered, strict=True) if d],
        }
