"""Water Filling: a slow ground vehicle and a fast drone keep three jars filled (docs/DESIGN.md §7).

The paper's image-based task, physics-grounded in MuJoCo instead of AI2-THOR. A 10 m x 10 m
living room whose furniture blocks ground paths (``assets/arenas/water_filling.xml``) holds three
jars on stands; their water levels drop at random and the vehicle (0.5 m/s) can refill a jar
within 1 m, while the drone (2 m/s, cruising at 1.5 m over the furniture) can only look.

One tick is 0.5 s of simulated time (vehicle: 0.25 m, drone: 1 m per tick at full speed) at a
5 ms physics step (the drone's attitude loop runs at 50 Hz). Rules applied after each tick's
physics, in this order:

1. **water**: every jar's random countdown and drop (:class:`~.water.WaterLevels`; an interval
   of 0 expires at the next tick);
2. **fill**: a fill requested this tick (Fill, NavToFill's last tick, primitive Fill) resets the
   jar to 1.0 if the vehicle is within ``fill_radius`` (planar) of it now;
3. **knowledge**: every jar within ``observe_radius`` of *any* robot has its last-known level
   set to the true one and its elapsed counter reset (the shared auxiliary observation);
4. **reward** on the true levels: ``sum_c (1 - 1 / (w_c + 0.001))`` (paper Eq. 6).

The liquid geom of every jar is resized whenever its level changes, so every render shows it.

The team and the number of jars are settings (``vehicles``, ``drones``, ``jars``:
:mod:`~.team`); a bigger team plays in a room tiled from the arena (:mod:`~.scene`), every
vehicle can fill, the knowledge is shared by all, and fills requested by several vehicles on one
tick are applied in agent order.

Moves go one tick toward the point one tick of travel away (a wall or furniture in the way
simply stops the robot). NavTo plans a collision-free path once at its start
(:class:`~maopg.sim.planning.GoalFieldPlanner`: the vehicle over the floor-level obstacle grid,
the drone over the cruise-level one) and follows its waypoints with the robot's own tracking
controller; it ends when the robot is within reach of the jar (``vehicle_reach`` /
``drone_standoff`` < 1 m, so the level is observed on that tick), or after the path's travel
time plus ``nav_slack_ticks``.

Observation vector of each robot (float32, :func:`~.constants.obs_layout`): last-known level of
every jar (3 by default), ticks since each was last observed divided by ``max_ticks``, and the
robot's own planar position divided by the room's half extent (so state-vector mode is learnable
without normalisation).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

import mujoco
import numpy as np

from maopg.options.base import Option
from maopg.sim.appearance import Surfaces
from maopg.sim.planning import GoalFieldPlanner, Route, occupancy_grid
from maopg.sim.props import JarHandle
from maopg.sim.robots.base import wrap_angle
from maopg.tasks.base import SceneTask
from maopg.tasks.layout import ObsLayout
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import FACE_CREEP, GROUND_BAND, obs_layout
from maopg.tasks.water_filling.options import option_sets
from maopg.tasks.water_filling.scene import build_scene, read_arena
from maopg.tasks.water_filling.team import Team
from maopg.tasks.water_filling.water import WaterLevels, jar_reward


class WaterFilling(SceneTask):
    """Vehicles and drones keep the jars filled (see the module docstring).

    Implements :class:`~maopg.tasks.water_filling.options.JarRules`, the interface its options
    act through.
    """

    name = "water_filling"
    Config = Config
    prop_classes: ClassVar[Mapping[str, str]] = {
        "jar": "jar",
        **dict.fromkeys(
            ("sofa", "armchair", "coffee_table", "tv_cabinet", "plant", "bookshelf"), "furniture"
        ),
    }
    """Segmentation: the jars (stand, glass and water) and the room's furniture."""
    surfaces = Surfaces(
        props=(
            "*bookshelf",
            "*sofa_*",
            "*coffee_table_*",
            "*armchair_*",
            "*tv_cabinet",
            "*tv",
            "*plant_*",
            "jar*/stand*",
        )
    )
    """The living room's furniture and the jars' stands (the jars and their water keep their
    colours: the water level is what the agents watch)."""

    def __init__(self, config: Config | None = None) -> None:
        self.config = config = config or Config()
        self.tick_seconds = config.tick_seconds
        self.team = team = Team.of(config)
        arena = read_arena(config)
        self.jar_xy = arena.jar_xy
        self._jar_xy = [tuple(float(v) for v in p) for p in self.jar_xy]  # fast Python access
        self.half_extent = arena.half_extent
        self.scene = build_scene(config, arena)
        self.agent_robots = tuple(self.scene.robots[name] for name in team.names)
        drones = team.drone_agents
        self._drones = tuple(self.agent_robots[a] for a in drones)
        self.vehicle, self.drone = self.agent_robots[0], self._drones[0]  # the first of each
        self._bodies = [r.root_body_id for r in self.agent_robots]
        self.jars = [
            JarHandle(self.scene.model, f"jar{c}", self.scene.data) for c in range(team.jars)
        ]
        model = self.scene.model
        self._jar_tops = [model.site(f"jar{c}/top").id for c in range(team.jars)]
        res = config.grid_resolution
        z = config.cruise_altitude
        # One planner per kind, shared by its robots (same robot, same grid, same fields).
        ground = GoalFieldPlanner(
            occupancy_grid(
                model, radius=self.vehicle.footprint_radius, resolution=res, z_band=GROUND_BAND
            )
        )
        band = (z - 0.2, z + 0.2)
        try:
            cruise_grid = occupancy_grid(
                model, radius=config.drone_radius, resolution=res, z_band=band
            )
        except ValueError:  # nothing at that height: not even the walls bound the room there
            raise ValueError(
                f"env.cruise_altitude={z:g}: no wall or obstacle reaches the drone's flight band "
                f"({band[0]:g}-{band[1]:g} m), so the room has no bounds there; fly lower"
            ) from None
        cruise = GoalFieldPlanner(cruise_grid)
        kinds = [team.is_drone(a) for a in range(team.size)]
        self.planners = tuple(cruise if d else ground for d in kinds)
        self._step_length = tuple(
            (r.constants.max_speed if d else r.max_speed) * config.tick_seconds
            for r, d in zip(self.agent_robots, kinds, strict=True)
        )
        self._reach = tuple(config.drone_standoff if d else config.vehicle_reach for d in kinds)
        self._arrive_tol = tuple(
            config.drone_arrive_tol if d else config.vehicle_arrive_tol for d in kinds
        )
        for agent in (0, drones[0]):  # every field now, so no episode pays for one
            for c in range(team.jars):
                self.planners[agent].field(self.jar_xy[c], self._reach[agent])
        self._drone_qpos_z = [
            int(model.jnt_qposadr[model.body_jntadr[d.root_body_id]]) + 2 for d in self._drones
        ]
        self.water = WaterLevels(config)
        self._options = option_sets(config)
        self._obs = obs_layout(team.jars)
        self.known = np.ones(team.jars)
        self.updated = np.zeros(team.jars, dtype=np.int64)
        self.reset(0)

    # --------------------------------------------------------------- static description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return self.team.names

    def robot_of(self, agent: int) -> str:
        return self.team.robot(self.config, agent)

    def options(self, agent: int) -> Sequence[Option[Any]]:
        return self._options[agent]

    def observation_layout(self, agent: int) -> ObsLayout:
        return self._obs

    # --------------------------------------------------------------- dynamics
    @property
    def ticks(self) -> int:
        return self._ticks

    def reset(self, seed: int) -> None:
        scene = self.scene
        scene.reset()
        # The drones start hovering at cruise altitude above their spawn points.
        scene.data.qpos[self._drone_qpos_z] = self.config.cruise_altitude
        mujoco.mj_forward(scene.model, scene.data)
        for drone in self._drones:
            drone.reset()
        self.water.reset(seed)
        for jar in self.jars:  # Scene.reset does not restore the liquid geoms
            jar.set_level(1.0)
        self.known[:] = 1.0
        self.updated[:] = 0
        self._ticks = 0
        self._fill_requests: dict[int, int] = {}  # vehicle -> jar, this tick
        self.fills = 0
        self.ran_dry = False

    def tick(self) -> float:
        c = self.config
        self.scene.advance(c.tick_seconds)
        self._ticks += 1
        water = self.water
        water.step()
        for agent, jar in sorted(self._fill_requests.items()):
            if self.can_fill(agent, jar):
                water.fill(jar)
                self.fills += 1
        self._fill_requests.clear()
        levels = water.levels
        for handle, level in zip(self.jars, levels, strict=True):
            if handle.level != level:
                handle.set_level(level)
        self.ran_dry = self.ran_dry or not levels.all()
        r2 = c.observe_radius**2
        xpos = self.scene.data.xpos
        for body in self._bodies:
            x, y = xpos[body, 0], xpos[body, 1]
            for jar, (jx, jy) in enumerate(self._jar_xy):
                if (x - jx) ** 2 + (y - jy) ** 2 <= r2:
                    self.known[jar] = levels[jar]
                    self.updated[jar] = self._ticks
        return jar_reward(levels, c.reward_eps)

    def terminated(self) -> bool:
        return False  # a continuing task: episodes end by truncation at max_ticks

    def solved(self) -> bool:
        """No jar ran dry during the episode."""
        return not self.ran_dry

    # --------------------------------------------------------------- MobileTask
    def planar_position(self, agent: int) -> tuple[float, float]:
        pos = self.scene.data.xpos[self._bodies[agent]]
        return float(pos[0]), float(pos[1])

    def step_length(self, agent: int) -> float:
        """One tick of full-speed travel."""
        return self._step_length[agent]

    def head_for(self, agent: int, xy: Sequence[float]) -> None:
        self._steer(agent, xy)

    def arrived(self, agent: int, xy: Sequence[float]) -> bool:
        x, y = self.planar_position(agent)
        return math.hypot(x - xy[0], y - xy[1]) <= self._arrive_tol[agent]

    def motion_started(self, agent: int) -> None:
        """Moving changes nothing in the rules of this task."""

    # --------------------------------------------------------------- JarRules
    def distance_to_jar(self, agent: int, jar: int) -> float:
        x, y = self.planar_position(agent)
        jx, jy = self._jar_xy[jar]
        return math.hypot(x - jx, y - jy)

    def can_fill(self, agent: int, jar: int) -> bool:
        return self.distance_to_jar(agent, jar) <= self.config.fill_radius

    def jar_in_reach(self, agent: int) -> int:
        jar = min(range(self.team.jars), key=lambda c: self.distance_to_jar(agent, c))
        return jar if self.can_fill(agent, jar) else -1

    def request_fill(self, agent: int, jar: int) -> None:
        self._fill_requests[agent] = jar

    def route_to(self, agent: int, jar: int) -> Route:
        start = self.planar_position(agent)
        waypoints = self.planners[agent].plan(start, self.jar_xy[jar], self._reach[agent])
        tol = self._arrive_tol[agent]
        return Route(waypoints, arrive_tol=tol, pass_tol=tol)

    def nav_deadline(self, agent: int, route: Route) -> int:
        """The route's travel time at full speed, rounded up, plus ``nav_slack_ticks``."""
        length = route.length_from(self.planar_position(agent))
        return math.ceil(length / self._step_length[agent]) + self.config.nav_slack_ticks

    def follow(self, agent: int, route: Route, jar: int) -> None:
        """Head for the route's current waypoint and, at the end, turn to face the jar.

        A drone yaws toward the jar on its last leg. A vehicle's heading follows its motion,
        so once at the end point it creeps ``FACE_CREEP`` m toward the jar (well inside the grid's
        clearance slack) until it faces it.
        """
        tx, ty = route.target
        jx, jy = self._jar_xy[jar]
        if self.team.is_drone(agent):
            yaw = math.atan2(jy - ty, jx - tx) if route.last_leg else None
            self._steer(agent, (tx, ty), yaw)
            return
        x, y = self.planar_position(agent)
        if route.last_leg and math.hypot(tx - x, ty - y) <= route.arrive_tol:
            d = math.hypot(jx - x, jy - y)
            tx, ty = x + FACE_CREEP * (jx - x) / d, y + FACE_CREEP * (jy - y) / d
        self._steer(agent, (tx, ty))

    def at_goal(self, agent: int, route: Route, jar: int) -> bool:
        """At the route's end, facing the jar (its camera sees the level)."""
        return route.update(self.planar_position(agent)) and self.facing(agent, jar)

    def facing(self, agent: int, jar: int) -> bool:
        """The robot's heading points at the jar within ``face_tol`` (its camera sees it)."""
        x, y = self.planar_position(agent)
        jx, jy = self._jar_xy[jar]
        error = wrap_angle(math.atan2(jy - y, jx - x) - self.agent_robots[agent].yaw)
        return abs(error) <= self.config.face_tol

    def set_levels(self, levels: Sequence[float]) -> None:
        """Set the true levels (tests, demos); the liquid geoms follow at once."""
        self.water.levels[:] = np.clip(levels, 0.0, 1.0)
        for jar, level in zip(self.jars, self.water.levels, strict=True):
            jar.set_level(level)

    def _steer(self, agent: int, xy: Sequence[float], yaw: float | None = None) -> None:
        """This tick's tracking command: drive (vehicle) or fly at cruise altitude (drone)."""
        robot = self.agent_robots[agent]
        if self.team.is_drone(agent):
            robot.fly_to((xy[0], xy[1], self.config.cruise_altitude), yaw=yaw)
        else:
            robot.drive_to(xy)

    # --------------------------------------------------------------- observations
    def observe(self, agent: int) -> np.ndarray:
        layout = self._obs
        obs = layout.zeros()
        obs[layout["known_levels"]] = self.known
        obs[layout["elapsed"]] = (self._ticks - self.updated) / self.config.max_ticks
        x, y = self.planar_position(agent)
        obs[layout["position"]] = (x / self.half_extent[0], y / self.half_extent[1])
        return obs

    def labels(self) -> list[tuple[str, np.ndarray]]:
        """The robots, and each jar's index over its glass (the jar prop's ``top`` site)."""
        site_xpos = self.scene.data.site_xpos
        jars = [(f"jar {c}", site_xpos[site].copy()) for c, site in enumerate(self._jar_tops)]
        return super().labels() + jars

    def describe(self) -> dict[str, object]:
        """Levels, knowledge, fills, and each robot's position (``<name>_xy`` for a vehicle,
        ``<name>_xyz`` for a drone)."""
        team = self.team
        where = {
            f"{name}_xyz" if team.is_drone(a) else f"{name}_xy": (
                self.agent_robots[a].position.tolist()
                if team.is_drone(a)
                else list(self.planar_position(a))
            )
            for a, name in enumerate(team.names)
        }
        return {
            "levels": self.water.levels.tolist(),
            "known_levels": self.known.tolist(),
            "elapsed": (self._ticks - self.updated).tolist(),
            **where,
            "fills": self.fills,
        }
