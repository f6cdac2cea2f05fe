"""Water Filling: a slow ground vehicle and a fast drone keep three jars filled (docs/DESIGN.md §7).

The paper's image-based task, physics-grounded in MuJoCo instead of AI2-THOR. A 10 m x 10 m
living room whose furniture blocks ground paths (``assets/arenas/water_filling.xml``) holds three
jars on stands; their water levels drop at random and the vehicle (0.5 m/s) can refill a jar
within 1 m, while the drone (2 m/s, cruising at 1.5 m over the furniture) can only look.

One tick is 0.5 s of simulated time (vehicle: 0.25 m, drone: 1 m per tick at full speed) at a
5 ms physics step (the drone's attitude loop runs at 50 Hz). Rules applied after each tick's
physics, in this order:

1. **water**: each jar counts down an interval ``round(Exp(scale=s))`` ticks, ``s`` drawn with
   ``rng.integers(*interval_scale)`` (numpy's ``randint``: high end excluded); on expiry the
   level drops by ``|N(interval * drop_mean_per_tick, drop_std)|`` (``interval / 500``, 0.2),
   clipped at 0, and a new interval is drawn (an interval of 0 expires at the next tick). Each
   jar has its own numpy ``Generator`` spawned from the reset seed;
2. **fill**: a fill requested this tick (Fill, NavToFill's last tick, primitive Fill) resets the
   jar to 1.0 if the vehicle is within ``fill_radius`` (planar) of it now;
3. **knowledge**: every jar within ``observe_radius`` of *any* robot has its last-known level
   set to the true one and its elapsed counter reset (the shared auxiliary observation);
4. **reward** on the true levels: ``sum_c (1 - 1 / (w_c + 0.001))`` (paper Eq. 6).

The liquid geom of every jar is resized whenever its level changes, so every render shows it.

Options (paper's table): both robots ``Up``/``Down``/``Left``/``Right`` (one tick toward the point
one tick of travel away; a wall or furniture in the way simply stops the robot) and
``NavTo(c)``; the vehicle also ``Fill(c)`` (one tick; available only within ``fill_radius`` of
jar ``c``) and ``NavToFill(c)`` (NavTo, then one Fill tick). Vehicle: 4 + 3 + 3 + 3 = 13 options,
drone: 4 + 3 = 7. NavTo plans a collision-free path once at its start
(:class:`~maopg.options.navigation.GoalFieldPlanner`: the vehicle over the floor-level obstacle
grid, the drone over the cruise-level one) and follows its waypoints with the robot's own
tracking controller; it ends when the robot is within reach of the jar (``vehicle_reach`` /
``drone_standoff`` < 1 m, so the level is observed on that tick), or after the path's travel
time plus ``nav_slack_ticks``. In ``primitive`` mode the vehicle has ``Up``/``Down``/``Left``/
``Right``/``Fill`` (the nearest jar in reach; masked when none is) and the drone the four moves.

Observation vector of each robot (float32, 8): last-known level of the 3 jars, ticks since each
was last observed divided by ``max_ticks``, and the robot's own planar position divided by the
room's half extent (so state-vector mode is learnable without normalisation).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.options.base import Execution, Option
from maopg.options.navigation import GoalFieldPlanner, Route
from maopg.sim.planning import occupancy_grid
from maopg.sim.props import JarHandle, layout_sites
from maopg.sim.robots import ASSETS_DIR
from maopg.sim.robots.base import wrap_angle
from maopg.sim.scene import SceneBuilder
from maopg.tasks.base import SceneTask, TaskConfig

AGENTS = ("vehicle", "drone")
VEHICLE, DRONE = 0, 1
NUM_JARS = 3
#: Compass moves in the top view: Up = +y (north), Right = +x (east).
MOVES = (("Up", (0.0, 1.0)), ("Down", (0.0, -1.0)), ("Left", (-1.0, 0.0)), ("Right", (1.0, 0.0)))
OBS_SIZE = 2 * NUM_JARS + 2
#: How far (m) the vehicle creeps toward a jar per tick to turn its heading onto it.
FACE_CREEP = 0.04
#: Floor-level obstacles for the vehicle; cruise-level ones for the drone (walls, bookshelf).
GROUND_BAND = (0.02, 0.8)


@dataclass(frozen=True)
class Config(TaskConfig):
    """Water Filling settings (docs/DESIGN.md §7 defaults)."""

    max_ticks: int = 300
    tick_seconds: float = 0.5
    timestep: float = 0.005
    """Physics step (s); the drone's 50 Hz controller runs every 4 steps (tuned for <= 5 ms)."""
    arena: str = "arenas/water_filling.xml"
    vehicle_robot: str = "vehicle"
    drone_robot: str = "drone"
    vehicle_start: tuple[float, float] | None = None
    """Planar start of the vehicle (default: the arena's ``spawn_vehicle`` site)."""
    drone_start: tuple[float, float] | None = None
    """Planar start of the drone (default: ``spawn_drone``); it starts hovering at cruise."""
    cruise_altitude: float = 1.5
    interval_scale: tuple[int, int] = (5, 15)
    """Exponential scale of a jar's drop interval: ``rng.integers(low, high)`` ticks."""
    drop_mean_per_tick: float = 1.0 / 500.0
    drop_std: float = 0.2
    fill_radius: float = 1.0
    observe_radius: float = 1.0
    reward_eps: float = 0.001
    grid_resolution: float = 0.1
    vehicle_reach: float = 0.8
    """NavTo of the vehicle ends at the first free cell within this distance of the jar (m)."""
    drone_standoff: float = 0.75
    """NavTo of the drone ends hovering this close to the jar (m), facing it."""
    drone_radius: float = 0.3
    """Drone footprint radius for its cruise-level planning grid (m)."""
    vehicle_arrive_tol: float = 0.05
    drone_arrive_tol: float = 0.15
    face_tol: float = 0.35
    """NavTo ends facing the jar within this angle (rad), so the camera shows its level."""
    nav_slack_ticks: int = 8
    """NavTo gives up after the path's travel time at full speed plus this many ticks."""


def jar_reward(levels: Sequence[float] | np.ndarray, eps: float = 0.001) -> float:
    """Paper Eq. 6: ``sum_c (1 - 1 / (w_c + eps))`` over the true levels."""
    return float(sum(1.0 - 1.0 / (float(w) + eps) for w in levels))


class WaterLevels:
    """The jars' random water dynamics (no physics; see the module docstring, rule 1)."""

    def __init__(self, config: Config, num_jars: int = NUM_JARS) -> None:
        self.config = config
        self.num_jars = num_jars
        self.levels = np.ones(num_jars)
        self.reset(0)

    def reset(self, seed: int) -> None:
        streams = np.random.SeedSequence(seed).spawn(self.num_jars)
        self._rngs = [np.random.default_rng(s) for s in streams]
        self.levels[:] = 1.0
        self._interval = [self._draw_interval(c) for c in range(self.num_jars)]
        self._left = list(self._interval)

    def _draw_interval(self, jar: int) -> int:
        rng = self._rngs[jar]
        scale = int(rng.integers(*self.config.interval_scale))
        return round(rng.exponential(scale))

    def step(self) -> None:
        """One tick of every jar's countdown; expired jars drop and draw a new interval."""
        c = self.config
        for jar in range(self.num_jars):
            self._left[jar] -= 1
            if self._left[jar] > 0:
                continue
            interval = self._interval[jar]
            drop = abs(self._rngs[jar].normal(interval * c.drop_mean_per_tick, c.drop_std))
            self.levels[jar] = max(0.0, self.levels[jar] - drop)
            self._interval[jar] = self._draw_interval(jar)
            self._left[jar] = self._interval[jar]

    def fill(self, jar: int) -> None:
        self.levels[jar] = 1.0


# ---------------------------------------------------------------------------- options
class Move(Option):
    """One tick toward the point one tick of full-speed travel away in a compass direction."""

    def __init__(self, name: str, direction: tuple[float, float]) -> None:
        self.name = name
        self.direction = direction

    def start(self, task: WaterFilling, ex: Execution) -> None:
        x, y = task.xy(ex.agent)
        step = task.step_length[ex.agent]
        ex.memo["target"] = (x + step * self.direction[0], y + step * self.direction[1])

    def step(self, task: WaterFilling, ex: Execution) -> None:
        task.go_to(ex.agent, ex.memo["target"])

    def done(self, task: WaterFilling, ex: Execution) -> bool:
        return True


class Fill(Option):
    """One tick holding still while filling jar ``jar`` (``None``: the nearest one in reach)."""

    def __init__(self, jar: int | None) -> None:
        self.jar = jar
        self.name = "Fill" if jar is None else f"Fill({jar})"

    def available(self, task: WaterFilling, agent: int) -> bool:
        if self.jar is None:
            return task.jar_in_reach() >= 0
        return task.can_fill(self.jar)

    def start(self, task: WaterFilling, ex: Execution) -> None:
        ex.memo["jar"] = task.jar_in_reach() if self.jar is None else self.jar

    def step(self, task: WaterFilling, ex: Execution) -> None:
        task.hold(ex.agent)
        task.request_fill(ex.memo["jar"])

    def done(self, task: WaterFilling, ex: Execution) -> bool:
        return True


class NavTo(Option):
    """Plan a path to jar ``jar`` and follow it; with ``fill``, then one Fill tick there."""

    def __init__(self, jar: int, *, fill: bool = False) -> None:
        self.jar, self.fill = jar, fill
        self.name = f"NavToFill({jar})" if fill else f"NavTo({jar})"

    def start(self, task: WaterFilling, ex: Execution) -> None:
        route = task.route_to(ex.agent, self.jar)
        ex.memo["route"] = route
        ex.memo["limit"] = task.travel_ticks(ex.agent, route) + task.config.nav_slack_ticks
        ex.memo["filling"] = False

    def step(self, task: WaterFilling, ex: Execution) -> None:
        if ex.memo["filling"]:
            task.hold(ex.agent)
            task.request_fill(self.jar)
        else:
            task.follow(ex.agent, ex.memo["route"], self.jar)

    def done(self, task: WaterFilling, ex: Execution) -> bool:
        if ex.memo["filling"]:
            return True  # the fill tick has run
        route = ex.memo["route"]
        arrived = route.update(task.xy(ex.agent)) and task.facing(ex.agent, self.jar)
        if not (arrived or ex.ticks >= ex.memo["limit"]):
            return False
        if self.fill and task.can_fill(self.jar):
            ex.memo["filling"] = True
            return False
        return True


# ---------------------------------------------------------------------------- the task
class WaterFilling(SceneTask):
    """Vehicle and drone keep three jars filled (see the module docstring)."""

    name = "water_filling"
    Config = Config

    def __init__(self, config: Config | None = None) -> None:
        self.config = config = config or Config()
        self.tick_seconds = config.tick_seconds
        arena = ASSETS_DIR / config.arena
        sites = layout_sites(arena)
        self.jar_xy = np.array([sites[f"jar_{c}"][:2] for c in range(NUM_JARS)])
        self._jar_xy = [tuple(float(v) for v in p) for p in self.jar_xy]  # fast Python access
        starts = (
            config.vehicle_start or tuple(sites["spawn_vehicle"][:2]),
            config.drone_start or tuple(sites["spawn_drone"][:2]),
        )
        self.scene = self._build_scene(config, arena, sites, starts)
        self.vehicle = self.scene.robots[AGENTS[VEHICLE]]
        self.drone = self.scene.robots[AGENTS[DRONE]]
        self.agent_robots = (self.vehicle, self.drone)
        self._bodies = [r.root_body_id for r in self.agent_robots]
        self.jars = [JarHandle(self.scene.model, f"jar{c}", self.scene.data) for c in range(3)]
        floor = self.scene.model.geom("floor")
        self.half_extent = (float(floor.size[0]), float(floor.size[1]))
        self.step_length = (
            self.vehicle.max_speed * config.tick_seconds,
            self.drone.constants.max_speed * config.tick_seconds,
        )
        model = self.scene.model
        res = config.grid_resolution
        z = config.cruise_altitude
        self.planners = (
            GoalFieldPlanner(
                occupancy_grid(
                    model, radius=self.vehicle.constants.radius, resolution=res, z_band=GROUND_BAND
                )
            ),
            GoalFieldPlanner(
                occupancy_grid(
                    model, radius=config.drone_radius, resolution=res, z_band=(z - 0.2, z + 0.2)
                )
            ),
        )
        self._reach = (config.vehicle_reach, config.drone_standoff)
        self._arrive_tol = (config.vehicle_arrive_tol, config.drone_arrive_tol)
        for agent in (VEHICLE, DRONE):  # every field now, so no episode pays for one
            for c in range(NUM_JARS):
                self.planners[agent].field(self.jar_xy[c], self._reach[agent])
        self._drone_qpos_z = int(model.jnt_qposadr[model.body_jntadr[self.drone.root_body_id]]) + 2
        self.water = WaterLevels(config)
        self._options = self._make_options(config)
        self.known = np.ones(NUM_JARS)
        self.updated = np.zeros(NUM_JARS, dtype=np.int64)
        self.reset(0)

    @staticmethod
    def _build_scene(config: Config, arena, sites, starts):
        builder = SceneBuilder(arena, timestep=config.timestep, render_size=config.image_size)
        for c in range(NUM_JARS):
            builder.add_prop(f"jar{c}", ASSETS_DIR / "props" / "jar.xml", sites[f"jar_{c}"])
        builder.add_robot(AGENTS[VEHICLE], config.vehicle_robot, (*starts[VEHICLE], 0.0))
        builder.add_robot(AGENTS[DRONE], config.drone_robot, (*starts[DRONE], 0.0))
        return builder.build()

    @staticmethod
    def _make_options(config: Config) -> list[tuple[Option, ...]]:
        moves = tuple(Move(name, d) for name, d in MOVES)
        if config.primitive:
            return [(*moves, Fill(None)), moves]
        vehicle = (
            *moves,
            *(Fill(c) for c in range(NUM_JARS)),
            *(NavTo(c) for c in range(NUM_JARS)),
            *(NavTo(c, fill=True) for c in range(NUM_JARS)),
        )
        drone = (*moves, *(NavTo(c) for c in range(NUM_JARS)))
        return [vehicle, drone]

    # --------------------------------------------------------------- static description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return AGENTS

    def robot_of(self, agent: int) -> str:
        return self.config.drone_robot if agent == DRONE else self.config.vehicle_robot

    def options(self, agent: int) -> Sequence[Option]:
        return self._options[agent]

    def vector_size(self, agent: int) -> int:
        return OBS_SIZE

    # --------------------------------------------------------------- dynamics
    @property
    def ticks(self) -> int:
        return self._ticks

    def reset(self, seed: int) -> None:
        scene = self.scene
        scene.reset()
        # The drone starts hovering at cruise altitude above its spawn point.
        scene.data.qpos[self._drone_qpos_z] = self.config.cruise_altitude
        mujoco.mj_forward(scene.model, scene.data)
        self.drone.reset()
        self.water.reset(seed)
        for jar in self.jars:  # Scene.reset does not restore the liquid geoms
            jar.set_level(1.0)
        self.known[:] = 1.0
        self.updated[:] = 0
        self._ticks = 0
        self._fill_request = -1
        self.fills = 0
        self.ran_dry = False

    def tick(self) -> float:
        c = self.config
        self.scene.advance(c.tick_seconds)
        self._ticks += 1
        water = self.water
        water.step()
        if self._fill_request >= 0:
            if self.can_fill(self._fill_request):
                water.fill(self._fill_request)
                self.fills += 1
            self._fill_request = -1
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

    # --------------------------------------------------------------- rules used by options
    def xy(self, agent: int) -> tuple[float, float]:
        pos = self.scene.data.xpos[self._bodies[agent]]
        return float(pos[0]), float(pos[1])

    def distance_to_jar(self, agent: int, jar: int) -> float:
        x, y = self.xy(agent)
        jx, jy = self._jar_xy[jar]
        return math.hypot(x - jx, y - jy)

    def can_fill(self, jar: int) -> bool:
        return self.distance_to_jar(VEHICLE, jar) <= self.config.fill_radius

    def jar_in_reach(self) -> int:
        """The nearest jar the vehicle can fill now, or -1."""
        jar = min(range(NUM_JARS), key=lambda c: self.distance_to_jar(VEHICLE, c))
        return jar if self.can_fill(jar) else -1

    def request_fill(self, jar: int) -> None:
        """Fill ``jar`` at the end of this tick if the vehicle is then within reach."""
        self._fill_request = jar

    def go_to(self, agent: int, xy: Sequence[float], yaw: float | None = None) -> None:
        """This tick's tracking command: drive (vehicle) or fly at cruise altitude (drone)."""
        if agent == DRONE:
            self.drone.fly_to((xy[0], xy[1], self.config.cruise_altitude), yaw=yaw)
        else:
            self.vehicle.drive_to(xy)

    def route_to(self, agent: int, jar: int) -> Route:
        waypoints = self.planners[agent].plan(self.xy(agent), self.jar_xy[jar], self._reach[agent])
        tol = self._arrive_tol[agent]
        return Route(waypoints, arrive_tol=tol, pass_tol=tol)

    def travel_ticks(self, agent: int, route: Route) -> int:
        """Ticks the route takes at full speed, rounded up."""
        return math.ceil(route.length_from(self.xy(agent)) / self.step_length[agent])

    def follow(self, agent: int, route: Route, jar: int) -> None:
        """Head for the route's current waypoint and, at the end, turn to face the jar.

        The drone yaws toward the jar on its last leg. The vehicle's heading follows its motion,
        so once at the end point it creeps ``FACE_CREEP`` m toward the jar (well inside the grid's
        clearance slack) until it faces it.
        """
        tx, ty = route.target
        jx, jy = self._jar_xy[jar]
        if agent == DRONE:
            yaw = math.atan2(jy - ty, jx - tx) if route.last_leg else None
            self.go_to(agent, (tx, ty), yaw)
            return
        x, y = self.xy(agent)
        if route.last_leg and math.hypot(tx - x, ty - y) <= route.arrive_tol:
            d = math.hypot(jx - x, jy - y)
            tx, ty = x + FACE_CREEP * (jx - x) / d, y + FACE_CREEP * (jy - y) / d
        self.go_to(agent, (tx, ty))

    def facing(self, agent: int, jar: int) -> bool:
        """The robot's heading points at the jar within ``face_tol`` (its camera sees it)."""
        x, y = self.xy(agent)
        jx, jy = self._jar_xy[jar]
        error = wrap_angle(math.atan2(jy - y, jx - x) - self.agent_robots[agent].yaw)
        return abs(error) <= self.config.face_tol

    def set_levels(self, levels: Sequence[float]) -> None:
        """Set the true levels (tests, demos); the liquid geoms follow at once."""
        self.water.levels[:] = np.clip(levels, 0.0, 1.0)
        for jar, level in zip(self.jars, self.water.levels, strict=True):
            jar.set_level(level)

    # --------------------------------------------------------------- observations
    def observe(self, agent: int) -> np.ndarray:
        obs = np.empty(OBS_SIZE, np.float32)
        obs[:NUM_JARS] = self.known
        obs[NUM_JARS : 2 * NUM_JARS] = (self._ticks - self.updated) / self.config.max_ticks
        x, y = self.xy(agent)
        obs[-2] = x / self.half_extent[0]
        obs[-1] = y / self.half_extent[1]
        return obs

    def describe(self) -> dict[str, object]:
        return {
            "levels": self.water.levels.tolist(),
            "known_levels": self.known.tolist(),
            "elapsed": (self._ticks - self.updated).tolist(),
            "vehicle_xy": list(self.xy(VEHICLE)),
            "drone_xyz": self.drone.position.tolist(),
            "fills": self.fills,
        }


# ---------------------------------------------------------------------------- scripted policy
#: Expected level drop per tick under the default dynamics: E|N(~0.02, 0.2)| ~ 0.16 every
#: E[interval] ~ 9.5 ticks. The scripted policy uses it to age what it knows.
_EXPECTED_DROP_PER_TICK = 0.017


def scripted_policy(spec: EnvSpec):
    """A hand-written reference policy that reads only the agents' observation vectors.

    Drone: patrol — fly to the jar whose level is stalest and so refresh the shared knowledge.
    Vehicle: NavToFill the jar expected to be lowest when it gets there: last-known level minus
    the expected drop over (ticks since observed + travel ticks at 0.25 m per tick along the
    straight line, padded by 30 % for detours).
    """
    if spec.strategy.value == "primitive":
        raise ValueError("the scripted Water Filling policy drives options, not primitive actions")
    arena = ASSETS_DIR / Config.arena
    sites = layout_sites(arena)
    jars = np.array([sites[f"jar_{c}"][:2] for c in range(NUM_JARS)])
    half_extent = mujoco.MjModel.from_xml_path(str(arena)).geom("floor").size[:2].copy()
    nav_to_fill = 4 + 2 * NUM_JARS  # vehicle: moves, Fill(c), NavTo(c), NavToFill(c)
    drone_nav_to = 4
    max_ticks = spec.max_ticks
    step = 0.5 * spec.tick_seconds  # vehicle metres per tick

    def act(point: DecisionPoint) -> np.ndarray:
        joint = point.running.copy()
        if point.choosing[VEHICLE]:
            obs = point.vectors[VEHICLE]
            known, elapsed = obs[:NUM_JARS], obs[NUM_JARS : 2 * NUM_JARS] * max_ticks
            xy = obs[-2:] * half_extent
            travel = 1.3 * np.hypot(*(jars - xy).T) / step
            expected = known - _EXPECTED_DROP_PER_TICK * (elapsed + travel)
            joint[VEHICLE] = nav_to_fill + int(np.argmin(expected))
        if point.choosing[DRONE]:
            elapsed = point.vectors[DRONE][NUM_JARS : 2 * NUM_JARS]
            joint[DRONE] = drone_nav_to + int(np.argmax(elapsed))
        return joint

    return act
