"""Tool Delivery: a Fetch and two Turtlebots bring three tools to a human, in MuJoCo.

The rules, numbers and option semantics follow the canonical warehouse task the paper and
Mac-DQN used (MacDeepMARL ``ObjSearchDelivery_v4``; docs/DESIGN.md §7 and the scripted
episode's trace ``tests/data/tool_delivery_scripted_trace.csv``): −1 per tick, +100 per delivery
of the tool the human needs now, −10 per failed pass, a human working through 4 stages of 18
ticks, at most 2 tools staged on the desk (FIFO), episode end at the last delivery or after 150
ticks.
What changes is the substrate: Turtlebots really drive (velocity servos, 0.6 m/s, one tick =
1 s), so arrivals and hence option durations come from the physics, and the Fetch arm really
carries tools from the shelf to the desk and into a Turtlebot's basket.

Tick counting matches the reference trace: a Turtlebot in ``GetTool`` counts the ticks it ends
at its desk spot (the arrival tick included); it is *ready* for a pass once that count is ≥ 1
and gives up when it exceeds ``max_wait_ticks`` (10 full ticks of waiting after arriving).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.options.base import Execution, Option
from maopg.sim.robots import ASSETS_DIR
from maopg.sim.scene import SceneBuilder
from maopg.tasks.base import SceneTask, TaskConfig

# Layout facts of the canonical task (docs/DESIGN.md §7), metres in the 7 m x 5 m world.
WORKSHOP = (6.0, 3.0)  # WA0, where the human takes deliveries
TOOL_ROOM_WAIT = (2.5, 3.5)  # the tool-room wait spot (GoToTR)
DESK_SPOTS = ((0.8, 3.0), (1.2, 3.0))  # where Turtlebot 0 / 1 waits for a pass
TURTLEBOT_STARTS = ((3.0, 1.5), (3.0, 2.5))
FETCH_BASE = (0.9, 1.8)
NUM_TOOLS = 3
NUM_STAGES = 4  # stages 0..2 each need tool 0..2; stage 3 is the work after the last tool

AGENTS = ("turtlebot0", "turtlebot1", "fetch")
T0, T1, FETCH = 0, 1, 2
GRIPPER = "fetch/gripper"
TOOL = "tool{}/tool"  # body of tool j in the arena
STAGE_ON, STAGE_OFF = (0.1, 0.85, 0.2, 1.0), (0.25, 0.25, 0.25, 1.0)


@dataclass(frozen=True)
class Config(TaskConfig):
    """Tool Delivery settings; the defaults are the canonical task's."""

    max_ticks: int = 150
    tick_seconds: float = 1.0
    timestep: float = 0.02  # stable for the servos and welds; 50 physics steps per tick
    turtlebot_robot: str = "turtlebot"
    fetch_robot: str = "fetch"
    human_stage_ticks: int = 18
    search_ticks: int = 6
    pass_ticks: int = 4
    max_wait_ticks: int = 10
    max_staged: int = 2
    step_reward: float = -1.0
    delivery_reward: float = 100.0
    failed_pass_reward: float = -10.0
    mask_options: bool = False
    """Mask searches of found tools (or with the desk full) and passes with nothing staged.
    Off by default: the canonical task lets the Fetch waste time on them."""
    arrive_tol: float = 0.05
    """A Turtlebot within this distance of a waypoint has arrived (m)."""
    primitive_step: float = 0.6
    """Distance of a one-tick primitive move (m): the Turtlebot's speed times one tick."""
    primitive_tol: float = 0.4
    """Arrival tolerance in primitive mode, where moves lie on a 0.6 m lattice."""


@dataclass
class Activity:
    """The Fetch's current search or pass, advanced one tick at a time."""

    kind: str  # "search" | "pass" | "wait"
    arg: int  # tool index for a search, Turtlebot index for a pass
    duration: int
    progress: int = 0
    ok: bool = True  # a pass that has not failed
    tool: int = -1  # the tool a pass carries (-1: none grasped)


@dataclass
class _State:
    staged: list[int] = field(default_factory=list)  # FIFO of tools on the desk
    found: list[bool] = field(default_factory=lambda: [False] * NUM_TOOLS)
    carried: list[list[int]] = field(default_factory=lambda: [[], []])
    delivered: list[bool] = field(default_factory=lambda: [False] * NUM_TOOLS)
    stage: int = 0
    stage_start: int = 0
    getting_tool: list[bool] = field(default_factory=lambda: [False, False])
    at_desk_ticks: list[int] = field(default_factory=lambda: [0, 0])  # GetTool's wait timer
    at_desk: list[bool] = field(default_factory=lambda: [False, False])  # waiting at the spot
    received: list[bool] = field(default_factory=lambda: [False, False])
    activity: Activity | None = None


# ---------------------------------------------------------------------------- Turtlebot options
class GoTo(Option):
    """Drive to a waypoint; ends on arrival (GoToWS, GoToTR)."""

    def __init__(self, name: str, target: tuple[float, float]) -> None:
        self.name = name
        self.target = target

    def step(self, task: ToolDelivery, ex: Execution) -> None:
        task.turtlebots[ex.agent].drive_to(self.target)

    def done(self, task: ToolDelivery, ex: Execution) -> bool:
        return task.turtlebots[ex.agent].at(self.target, task.config.arrive_tol)


class GetTool(Option):
    """Drive to the own desk spot and wait; ends when a pass to this robot completes, or after
    ``max_wait_ticks`` of waiting."""

    name = "GetTool"

    def start(self, task: ToolDelivery, ex: Execution) -> None:
        task.begin_waiting(ex.agent)

    def step(self, task: ToolDelivery, ex: Execution) -> None:
        task.turtlebots[ex.agent].drive_to(DESK_SPOTS[ex.agent])

    def done(self, task: ToolDelivery, ex: Execution) -> bool:
        s = task.state
        return s.received[ex.agent] or s.at_desk_ticks[ex.agent] > task.config.max_wait_ticks

    def finish(self, task: ToolDelivery, ex: Execution) -> None:
        task.state.getting_tool[ex.agent] = False


class Move(Option):
    """Primitive: move one tick (0.6 m) in a compass direction."""

    def __init__(self, name: str, direction: tuple[float, float]) -> None:
        self.name = name
        self.direction = direction

    def start(self, task: ToolDelivery, ex: Execution) -> None:
        task.state.getting_tool[ex.agent] = False
        pos = task.turtlebots[ex.agent].position
        step = task.config.primitive_step
        ex.memo["target"] = (pos[0] + step * self.direction[0], pos[1] + step * self.direction[1])

    def step(self, task: ToolDelivery, ex: Execution) -> None:
        task.turtlebots[ex.agent].drive_to(ex.memo["target"])

    def done(self, task: ToolDelivery, ex: Execution) -> bool:
        return True


class Stay(Option):
    """Primitive: stay one tick; at the own desk spot this is waiting for a pass."""

    name = "Stay"

    def start(self, task: ToolDelivery, ex: Execution) -> None:
        task.begin_waiting(ex.agent, primitive=True)

    def step(self, task: ToolDelivery, ex: Execution) -> None:
        task.hold(ex.agent)

    def done(self, task: ToolDelivery, ex: Execution) -> bool:
        return True


# ---------------------------------------------------------------------------- Fetch options
class FetchActivity(Option):
    """Wait (1 tick), PassTo(w) (4 ticks) or SearchTool(j) (6 ticks) as an option.

    In primitive mode (``one_tick``) the option lasts one tick and only *advances* the activity:
    a search or pass completes only if it is chosen for its whole duration.
    """

    def __init__(self, kind: str, arg: int = -1, *, one_tick: bool = False) -> None:
        self.kind, self.arg, self.one_tick = kind, arg, one_tick
        self.name = {"wait": "Wait", "pass": f"PassTo({arg})", "search": f"SearchTool({arg})"}[kind]

    def available(self, task: ToolDelivery, agent: int) -> bool:
        """Everything is available in the canonical task (a pointless search or an empty pass
        just wastes ticks); ``mask_options`` masks those, as a user may prefer."""
        s = task.state
        if not task.config.mask_options or task.continues(self.kind, self.arg):
            return True
        if self.kind == "pass":
            return bool(s.staged)
        if self.kind == "search":
            return not s.found[self.arg] and len(s.staged) < task.config.max_staged
        return True

    def start(self, task: ToolDelivery, ex: Execution) -> None:
        if not (self.one_tick and task.continues(self.kind, self.arg)):
            task.begin_activity(self.kind, self.arg)

    def step(self, task: ToolDelivery, ex: Execution) -> None:
        task.command_arm()

    def done(self, task: ToolDelivery, ex: Execution) -> bool:
        return self.one_tick or task.state.activity is None

    def interrupt(self, task: ToolDelivery, ex: Execution) -> None:
        task.abort_activity()


# ---------------------------------------------------------------------------- the task
class ToolDelivery(SceneTask):
    """Three robots, three tools, one human (see the module docstring)."""

    name = "tool_delivery"
    Config = Config

    def __init__(self, config: Config | None = None) -> None:
        self.config = config = config or Config()
        self.tick_seconds = config.tick_seconds
        self.scene = self._build_scene(config)
        self.turtlebots = [self.scene.robots[AGENTS[T0]], self.scene.robots[AGENTS[T1]]]
        self.fetch = self.scene.robots[AGENTS[FETCH]]
        self.agent_robots = (*self.turtlebots, self.fetch)
        self._sites = {
            name: self.scene.site_position(name)
            for name in (
                *(f"shelf/slot{j}" for j in range(NUM_TOOLS)),
                *(f"desk/slot{k}" for k in range(config.max_staged)),
                *(f"human/slot{j}" for j in range(NUM_TOOLS)),
            )
        }
        self._options = self._make_options(config)
        self.reset(0)

    # --------------------------------------------------------------- construction
    @staticmethod
    def _build_scene(config: Config):
        builder = SceneBuilder(
            ASSETS_DIR / "arenas" / "tool_delivery.xml",
            timestep=config.timestep,
            render_size=config.image_size,
        )
        for w, (x, y) in enumerate(TURTLEBOT_STARTS):
            builder.add_robot(AGENTS[w], config.turtlebot_robot, (x, y, 0.0), yaw=math.pi)
        builder.add_robot(AGENTS[FETCH], config.fetch_robot, (*FETCH_BASE, 0.0), yaw=0.0)
        holders = [None, GRIPPER] + [f"{a}/basket" for a in AGENTS[:2]]
        for j in range(NUM_TOOLS):
            builder.add_attachable(TOOL.format(j), holders)
        return builder.build()

    def _make_options(self, config: Config) -> list[tuple[Option, ...]]:
        if config.primitive:
            moves = (("North", (0, 1)), ("South", (0, -1)), ("East", (1, 0)), ("West", (-1, 0)))
            turtle = (*(Move(n, d) for n, d in moves), Stay())
            fetch = (
                FetchActivity("pass", 0, one_tick=True),
                FetchActivity("pass", 1, one_tick=True),
                *(FetchActivity("search", j, one_tick=True) for j in range(NUM_TOOLS)),
                FetchActivity("wait", one_tick=True),
            )
        else:
            turtle = (GoTo("GoToWS", WORKSHOP), GoTo("GoToTR", TOOL_ROOM_WAIT), GetTool())
            fetch = (
                FetchActivity("pass", 0),
                FetchActivity("pass", 1),
                *(FetchActivity("search", j) for j in range(NUM_TOOLS)),
                FetchActivity("wait"),
            )
        return [turtle, turtle, fetch]

    # --------------------------------------------------------------- static description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return AGENTS

    def robot_of(self, agent: int) -> str:
        return self.config.fetch_robot if agent == FETCH else self.config.turtlebot_robot

    def options(self, agent: int) -> Sequence[Option]:
        return self._options[agent]

    def vector_size(self, agent: int) -> int:
        # Turtlebot: location (WA0, wait spot, desk, moving) + human stage (4, at WA0 only)
        # + tools carried (3) + tools staged on the desk (0, 1, 2; hidden at WA0).
        # Fetch: tools staged (0, 1, 2) + which Turtlebot is waiting at the desk (2).
        return 5 if agent == FETCH else 14

    # --------------------------------------------------------------- dynamics
    @property
    def ticks(self) -> int:
        return self._ticks

    def reset(self, seed: int) -> None:
        # Tool Delivery has no random elements (the canonical task is deterministic given the
        # options); the seed is accepted for the contract and costs nothing.
        del seed
        self.scene.reset()
        self.state = _State()
        self._ticks = 0
        self._holding = -1  # tool in the Fetch's gripper
        self._slot_of: dict[int, int] = {}  # desk slot of each staged tool
        self._show_stage()

    def tick(self) -> float:
        s, c = self.state, self.config
        s.received[:] = [False, False]
        self.scene.advance(c.tick_seconds)
        self._ticks += 1
        # The Fetch's activity is judged on the state at the start of the tick (readiness for
        # a pass means having waited at the spot through the previous tick).
        reward = c.step_reward + self._advance_activity()
        for w in (T0, T1):
            s.at_desk[w] = s.getting_tool[w] and self._at(w, DESK_SPOTS[w])
            s.at_desk_ticks[w] += s.at_desk[w]
        reward += self._deliver()
        self._advance_human()
        return reward

    def terminated(self) -> bool:
        return self.state.delivered[NUM_TOOLS - 1]

    # --------------------------------------------------------------- rules used by options
    def begin_waiting(self, w: int, *, primitive: bool = False) -> None:
        """Turtlebot ``w`` starts waiting for a pass (GetTool, or a primitive Stay at its spot)."""
        s = self.state
        if primitive:
            s.getting_tool[w] = self._at(w, DESK_SPOTS[w])
        else:
            s.getting_tool[w] = True
            s.at_desk_ticks[w] = 0

    def ready_for_pass(self, w: int) -> bool:
        """Turtlebot ``w`` waits for a tool and already ended the previous tick at its spot."""
        s = self.state
        return s.getting_tool[w] and s.at_desk[w]

    def continues(self, kind: str, arg: int) -> bool:
        """Whether the Fetch's unfinished activity is ``kind(arg)`` (primitive mode)."""
        a = self.state.activity
        return a is not None and a.kind == kind and a.arg == arg

    def begin_activity(self, kind: str, arg: int) -> None:
        s, c = self.state, self.config
        self.abort_activity()
        duration = {"wait": 1, "pass": c.pass_ticks, "search": c.search_ticks}[kind]
        activity = Activity(kind, arg, duration)
        if kind == "pass":  # whether it fails is known at its first tick (_advance_activity)
            activity.tool = s.staged[0] if s.staged else -1
        elif kind == "search":  # searching a found tool, or with the desk full, finds nothing
            activity.ok = not s.found[arg] and len(s.staged) < c.max_staged
        s.activity = activity

    def abort_activity(self) -> None:
        """Drop an unfinished activity (interrupted, or replaced in primitive mode).

        A tool in the gripper goes back where the activity found it, so the bookkeeping
        (staged / found) and the scene agree.
        """
        a = self.state.activity
        if a is not None:
            grasped = a.kind == "search" and a.progress >= 2
            tool = self._holding if self._holding >= 0 else (a.arg if grasped else -1)
            if tool >= 0:
                self._release(None)
                slot = f"desk/slot{self._slot_of[tool]}" if a.kind == "pass" else ""
                self.scene.place(TOOL.format(tool), self._sites[slot or f"shelf/slot{tool}"])
        self.state.activity = None

    def command_arm(self) -> None:
        """This tick's arm set-points for the current activity (keyframes per tick)."""
        a = self.state.activity
        if a is None or a.kind == "wait":
            self.fetch.hold()
            return
        target = self._arm_keyframe(a)
        self.fetch.set_arm_targets(self.fetch.ik(target))

    # --------------------------------------------------------------- internals
    def _at(self, w: int, xy: tuple[float, float]) -> bool:
        tol = self.config.primitive_tol if self.config.primitive else self.config.arrive_tol
        return self.turtlebots[w].at(xy, tol)

    def _arm_keyframe(self, a: Activity) -> np.ndarray:
        """Where the gripper should be during tick ``a.progress + 1`` of the activity.

        A search: above the shelf slot, down (grasp), up, above a free desk slot, down
        (release), up. A pass: down on the oldest staged tool (grasp), over the Turtlebot's
        basket, down (release), back up. A failed pass reaches out empty-handed, or brings a
        grasped tool back to its desk slot.
        """
        lift = np.array([0.0, 0.0, 0.15])
        if a.kind == "search":
            shelf = self._sites[f"shelf/slot{a.arg}"]
            desk = self._sites[f"desk/slot{self._slot_for_search()}"]
            return (shelf + lift, shelf, shelf + lift, desk + lift, desk, desk + lift)[a.progress]
        desk = self._sites[f"desk/slot{self._slot_of.get(a.tool, 0)}"]
        basket = self.scene.site_position(f"{AGENTS[a.arg]}/load")
        if not a.ok:  # reach over the desk spot, wherever the Turtlebot actually is
            basket[:2] = DESK_SPOTS[a.arg]
        if not a.ok and a.progress >= 1 and a.tool >= 0 and self._holding == a.tool:
            return desk  # take the tool back to where it was
        return (desk, basket + lift, basket + lift * 0.3, desk + lift)[a.progress]

    def _slot_for_search(self) -> int:
        """The free desk slot a found tool goes to (slot 0 for a search that finds nothing)."""
        used = {self._slot_of[j] for j in self.state.staged}
        return min(set(range(self.config.max_staged)) - used, default=0)

    def _advance_activity(self) -> float:
        """Advance the Fetch's activity one tick; grasps, releases, and the pass rules."""
        s, c, a = self.state, self.config, self.state.activity
        if a is None:
            return 0.0
        reward = 0.0
        if a.kind == "pass" and a.progress == 0:
            # Judged once every agent has started this tick's options, so a Turtlebot that
            # re-chooses GetTool at the same decision point still counts as waiting.
            a.ok = self.ready_for_pass(a.arg)
            reward += 0.0 if a.ok else c.failed_pass_reward
        elif a.kind == "pass" and a.ok and not s.getting_tool[a.arg]:
            a.ok = False  # the Turtlebot stopped waiting before the pass ended
            reward += c.failed_pass_reward
        a.progress += 1
        if a.kind == "search" and a.ok:
            if a.progress == 2:
                self._grasp(a.arg)
            elif a.progress == 5:
                self._slot_of[a.arg] = self._slot_for_search()
                self._release(None)
        elif a.kind == "pass" and a.tool >= 0:
            if a.progress == 1 and a.ok:
                self._grasp(a.tool)
            elif a.progress == 3 and self._holding == a.tool:
                self._release(f"{AGENTS[a.arg]}/basket" if a.ok else None)
        if a.progress < a.duration:
            return reward
        if a.kind == "search" and a.ok:
            s.found[a.arg] = True
            s.staged.append(a.arg)
        elif a.kind == "pass" and a.ok and a.tool >= 0:
            s.staged.remove(a.tool)
            s.carried[a.arg].append(a.tool)
            s.received[a.arg] = True
        s.activity = None
        return reward

    def _grasp(self, tool: int) -> None:
        self.fetch.set_gripper(True)
        self.scene.attach(TOOL.format(tool), GRIPPER)
        self._holding = tool

    def _release(self, holder: str | None) -> None:
        self.fetch.set_gripper(False)
        if self._holding >= 0:
            self.scene.attach(TOOL.format(self._holding), holder)
        self._holding = -1

    def _deliver(self) -> float:
        s, c = self.state, self.config
        reward = 0.0
        needed = s.stage
        if needed >= NUM_TOOLS or s.delivered[needed]:
            return reward
        for w in (T0, T1):
            if needed in s.carried[w] and self._at(w, WORKSHOP):
                s.carried[w].remove(needed)
                s.delivered[needed] = True
                # The human takes the tool off the basket onto the workbench.
                self.scene.place(TOOL.format(needed), self._sites[f"human/slot{needed}"])
                reward += c.delivery_reward
                break
        return reward

    def _advance_human(self) -> None:
        s = self.state
        if s.stage >= NUM_TOOLS:
            return
        if s.delivered[s.stage] and self._ticks - s.stage_start >= self.config.human_stage_ticks:
            s.stage += 1
            s.stage_start = self._ticks
            self._show_stage()

    def _show_stage(self) -> None:
        """Light the human's progress bar up to the current stage (visible in renders)."""
        for k in range(NUM_STAGES):
            lit = k <= self.state.stage
            self.scene.set_geom_rgba(f"human/stage{k}", STAGE_ON if lit else STAGE_OFF)

    # --------------------------------------------------------------- observations
    def observe(self, agent: int) -> np.ndarray:
        s = self.state
        if agent == FETCH:
            obs = np.zeros(5, np.float32)
            obs[min(len(s.staged), 2)] = 1.0
            obs[3] = self.ready_for_pass(T0)
            obs[4] = self.ready_for_pass(T1)
            return obs
        obs = np.zeros(14, np.float32)
        at_ws = self._at(agent, WORKSHOP)
        if at_ws:
            obs[0] = 1.0
        elif self._at(agent, TOOL_ROOM_WAIT):
            obs[1] = 1.0
        elif self._at(agent, DESK_SPOTS[agent]):
            obs[2] = 1.0
        else:
            obs[3] = 1.0
        if at_ws:
            obs[4 + s.stage] = 1.0
        for j in s.carried[agent]:
            obs[8 + j] = 1.0
        if not at_ws:
            obs[11 + min(len(s.staged), 2)] = 1.0
        return obs

    def describe(self) -> dict[str, object]:
        s = self.state
        return {
            "human_stage": s.stage,
            "staged": list(s.staged),
            "carried": [list(c) for c in s.carried],
            "delivered": list(s.delivered),
        }


# ---------------------------------------------------------------------------- scripted policy
def scripted_policy(spec: EnvSpec):
    """The hand-written reference policy, from the agents' own observations only.

    Turtlebots: carrying a tool -> GoToWS, else GetTool. Fetch: a tool staged and a Turtlebot
    ready -> PassTo(it); else search the next tool (in order) if the desk has room; else Wait.
    This reproduces the reference trace's decisions (canonical: return 259 in 41 ticks).
    """
    if spec.strategy.value == "primitive":
        raise ValueError("the scripted Tool Delivery policy drives options, not primitive actions")
    go_ws, get_tool = 0, 2
    pass_to, search, wait = (0, 1), (2, 3, 4), 5

    searched = [0]  # tools whose search the policy has started this episode (its only memory)

    def act(point: DecisionPoint) -> np.ndarray:
        if point.ticks == 0:
            searched[0] = 0
        joint = point.running.copy()
        for w in (T0, T1):
            carrying = point.vectors[w][8:11].any()
            joint[w] = go_ws if carrying else get_tool
        if point.choosing[FETCH]:
            fetch_obs = point.vectors[FETCH]
            ready = [w for w in (T0, T1) if fetch_obs[3 + w] > 0]
            if fetch_obs[0] == 0 and ready:
                joint[FETCH] = pass_to[ready[0]]
            elif searched[0] < NUM_TOOLS and fetch_obs[2] == 0:  # a tool left, desk not full
                joint[FETCH] = search[searched[0]]
                searched[0] += 1
            else:
                joint[FETCH] = wait
        return joint

    return act
