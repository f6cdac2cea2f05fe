"""Tool Delivery: a Fetch and two Turtlebots bring three tools to a human, in MuJoCo — or, with
the ``turtlebots`` / ``fetches`` / ``humans`` settings, a larger team (layout and names in
:mod:`~maopg.tasks.tool_delivery.team`).

The rules, numbers and option semantics follow the canonical warehouse task the paper and
Mac-DQN used (MacDeepMARL ``ObjSearchDelivery_v4``; docs/DESIGN.md §7 and the scripted
episode's trace ``tests/data/tool_delivery_scripted_trace.csv``): −1 per tick, +100 per delivery
of the tool the human needs now, −10 per failed pass, a human working through 4 stages of 18
ticks, at most 2 tools staged on the desk (FIFO), episode end at the last delivery or after 150
ticks.
What changes is the substrate: Turtlebots really drive (velocity servos, 0.6 m/s, one tick =
1 s), so arrivals and hence option durations come from the physics, and the Fetch arm really
carries tools from the shelf to the desk and into a Turtlebot's basket.

A larger team follows the same rules per Fetch and per human: each Fetch stages its own tools
on its own desk (at most ``max_staged``) and passes to any Turtlebot waiting at its desk; each
human works through its own four stages, +100 for every useful delivery at its workshop, and the
episode ends when every human has all its tools (or after ``max_ticks``, 150 at every size).

Tick counting matches the reference trace: a Turtlebot in ``GetTool`` counts the ticks it ends
at its desk spot (the arrival tick included); it is *ready* for a pass once that count is ≥ 1
and gives up when it exceeds ``max_wait_ticks`` (10 full ticks of waiting after arriving).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from maopg.options.base import Option
from maopg.sim.appearance import Surfaces
from maopg.tasks.base import SceneTask
from maopg.tasks.layout import ObsLayout
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import (
    BASKET,
    MAX_STAGED_SEEN,
    NUM_STAGES,
    NUM_TOOLS,
    STAGE_OFF,
    STAGE_ON,
    TOOL,
)
from maopg.tasks.tool_delivery.options import option_sets
from maopg.tasks.tool_delivery.scene import build_scene
from maopg.tasks.tool_delivery.team import Team


@dataclass
class Activity:
    """A Fetch's current search or pass, advanced one tick at a time."""

    kind: str  # "search" | "pass" | "wait"
    arg: int  # tool index for a search, Turtlebot index for a pass
    duration: int
    progress: int = 0
    ok: bool = True  # a pass that has not failed
    tool: int = -1  # the tool a pass carries (-1: none grasped)


@dataclass
class _State:
    """The rules' state: per Fetch (desk, activity), per human (stage), per Turtlebot, per tool."""

    team: Team
    desks: list[list[int]] = field(init=False)  # per Fetch: FIFO of tools on its desk
    activities: list[Activity | None] = field(init=False)  # per Fetch
    found: list[bool] = field(init=False)  # per tool
    delivered: list[bool] = field(init=False)  # per tool
    stages: list[int] = field(init=False)  # per human
    stage_starts: list[int] = field(init=False)  # per human
    carried: list[list[int]] = field(init=False)  # per Turtlebot
    getting_tool: list[int] = field(init=False)  # per Turtlebot: the Fetch it waits for, or -1
    at_desk_ticks: list[int] = field(init=False)  # GetTool's wait timer
    at_desk: list[int] = field(init=False)  # the Fetch at whose desk spot it waited, or -1
    received: list[bool] = field(init=False)

    def __post_init__(self) -> None:
        team = self.team
        self.desks = [[] for _ in team.fetch_ids]
        self.activities = [None for _ in team.fetch_ids]
        self.found = [False] * team.num_tools
        self.delivered = [False] * team.num_tools
        self.stages = [0] * team.humans
        self.stage_starts = [0] * team.humans
        self.carried = [[] for _ in team.turtlebot_ids]
        self.getting_tool = [-1] * team.turtlebots
        self.at_desk_ticks = [0] * team.turtlebots
        self.at_desk = [-1] * team.turtlebots
        self.received = [False] * team.turtlebots

    @property
    def stage(self) -> int:
        """Human 0's stage (the canonical task's one human)."""
        return self.stages[0]

    @property
    def staged(self) -> list[int]:
        """Fetch 0's desk (the canonical task's one desk)."""
        return self.desks[0]


class ToolDelivery(SceneTask):
    """Turtlebots, Fetches, humans and their tools (see the module docstring).

    Implements :class:`~maopg.tasks.tool_delivery.options.DeliveryRules`, the interface its
    options act through.
    """

    name = "tool_delivery"
    Config = Config
    prop_classes: ClassVar[Mapping[str, str]] = {
        "desk": "desk",
        "shelf": "shelf",
        "human": "human",
        "tool": "tool",
    }
    """Segmentation: the tool room's desk and shelves, the humans (their bench and stage
    panel too), the tools."""
    surfaces = Surfaces(props=("desk*/cabinet", "desk*/top", "shelf*/*", "human*/bench*"))
    """The furniture: desks, shelves (the tools on them keep their colours: an agent tells them
    apart by them) and the humans' workbenches (the stage panel shows the rules' state)."""

    def __init__(self, config: Config | None = None) -> None:
        self.config = config = config or Config()
        self.team = team = Team.of(config)
        self.tick_seconds = config.tick_seconds
        self.scene = build_scene(config)
        self.turtlebots = [self.scene.robots[team.agents[w]] for w in team.turtlebot_ids]
        self.arms = [self.scene.robots[team.agents[team.fetch_agent(f)]] for f in team.fetch_ids]
        self.fetch = self.arms[0]
        """Fetch 0's adapter (the canonical task's one Fetch)."""
        self.agent_robots = (*self.turtlebots, *self.arms)
        self._sites = {
            name: self.scene.site_position(name)
            for name in (
                *(team.shelf_slot(t) for t in range(team.num_tools)),
                *(team.bench_slot(t) for t in range(team.num_tools)),
                *(self._desk_slot(f, k) for f in team.fetch_ids for k in range(config.max_staged)),
            )
        }
        model = self.scene.model
        self._human_bodies = [model.body(f"{team.human(h)}/human").id for h in range(team.humans)]
        self._options = option_sets(config)
        self.reset(0)

    # --------------------------------------------------------------- static description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return self.team.agents

    def robot_of(self, agent: int) -> str:
        c = self.config
        return c.fetch_robot if agent >= self.team.turtlebots else c.turtlebot_robot

    def options(self, agent: int) -> Sequence[Option[Any]]:
        return self._options[agent]

    def observation_layout(self, agent: int) -> ObsLayout:
        team = self.team
        return team.fetch_layout if agent >= team.turtlebots else team.turtlebot_layout

    # --------------------------------------------------------------- dynamics
    @property
    def ticks(self) -> int:
        return self._ticks

    def reset(self, seed: int) -> None:
        # Tool Delivery has no random elements (the canonical task is deterministic given the
        # options); the seed is accepted for the contract and costs nothing.
        del seed
        self.scene.reset()
        self.state = _State(self.team)
        self._ticks = 0
        self._holding = [-1] * self.team.fetches  # tool in each Fetch's gripper
        self._slot_of: dict[int, int] = {}  # desk slot of each staged tool
        for h in range(self.team.humans):
            self._show_stage(h)

    def tick(self) -> float:
        s, c = self.state, self.config
        s.received[:] = [False] * self.team.turtlebots
        self.scene.advance(c.tick_seconds)
        self._ticks += 1
        # The Fetches' activities are judged on the state at the start of the tick (readiness
        # for a pass means having waited at the spot through the previous tick).
        reward = c.step_reward + sum(self._advance_activity(f) for f in self.team.fetch_ids)
        for w in self.team.turtlebot_ids:
            f = s.getting_tool[w]
            s.at_desk[w] = f if f >= 0 and self.arrived(w, self.team.desk_spot(f, w)) else -1
            s.at_desk_ticks[w] += s.at_desk[w] >= 0
        reward += self._deliver()
        for h in range(self.team.humans):
            self._advance_human(h)
        return reward

    def terminated(self) -> bool:
        delivered = self.state.delivered
        return all(delivered[self.team.tool(h, NUM_TOOLS - 1)] for h in range(self.team.humans))

    # --------------------------------------------------------------- MobileTask (Turtlebots)
    def planar_position(self, agent: int) -> tuple[float, float]:
        pos = self.turtlebots[agent].position
        return float(pos[0]), float(pos[1])

    def step_length(self, agent: int) -> float:
        return self.config.primitive_step

    def head_for(self, agent: int, xy: Sequence[float]) -> None:
        self.turtlebots[agent].drive_to(xy)

    def arrived(self, agent: int, xy: Sequence[float]) -> bool:
        c = self.config
        return self.turtlebots[agent].at(xy, c.primitive_tol if c.primitive else c.arrive_tol)

    def motion_started(self, agent: int) -> None:
        """A Turtlebot that drives off stops waiting for a pass."""
        self.stop_waiting(agent)

    # --------------------------------------------------------------- DeliveryRules
    def begin_waiting(self, w: int, fetch: int = 0, *, primitive: bool = False) -> None:
        s, team = self.state, self.team
        if primitive:
            at = [f for f in team.fetch_ids if self.arrived(w, team.desk_spot(f, w))]
            s.getting_tool[w] = at[0] if at else -1
        else:
            s.getting_tool[w] = fetch
            s.at_desk_ticks[w] = 0

    def waiting_over(self, w: int) -> bool:
        s = self.state
        return s.received[w] or s.at_desk_ticks[w] > self.config.max_wait_ticks

    def stop_waiting(self, w: int) -> None:
        self.state.getting_tool[w] = -1

    def ready_for_pass(self, f: int, w: int) -> bool:
        """Turtlebot ``w`` waits for a tool from Fetch ``f`` and already ended the previous
        tick at its spot there."""
        s = self.state
        return s.getting_tool[w] == f and s.at_desk[w] == f

    def activity_available(self, agent: int, kind: str, arg: int) -> bool:
        """Everything is available in the canonical task (a pointless search or an empty pass
        just wastes ticks); ``mask_options`` masks those, as a user may prefer."""
        if not self.config.mask_options or self.continues(agent, kind, arg):
            return True
        f = self.team.fetch_of_agent(agent)
        if kind == "pass":
            return bool(self.state.desks[f])
        if kind == "search":
            return self._search_finds(f, arg)
        return True

    def continues(self, agent: int, kind: str, arg: int) -> bool:
        a = self.state.activities[self.team.fetch_of_agent(agent)]
        return a is not None and a.kind == kind and a.arg == arg

    def begin_activity(self, agent: int, kind: str, arg: int) -> None:
        s, c, f = self.state, self.config, self.team.fetch_of_agent(agent)
        self.abort_activity(agent)
        duration = {"wait": 1, "pass": c.pass_ticks, "search": c.search_ticks}[kind]
        activity = Activity(kind, arg, duration)
        if kind == "pass":  # whether it fails is known at its first tick (_advance_activity)
            activity.tool = s.desks[f][0] if s.desks[f] else -1
        elif kind == "search":  # searching a found tool, or with the desk full, finds nothing
            activity.ok = self._search_finds(f, arg)
        s.activities[f] = activity

    def fetch_busy(self, agent: int) -> bool:
        return self.state.activities[self.team.fetch_of_agent(agent)] is not None

    def abort_activity(self, agent: int) -> None:
        """Drop an unfinished activity (interrupted, or replaced in primitive mode).

        A tool in the gripper goes back where the activity found it, so the bookkeeping
        (staged / found) and the scene agree. A search that finds nothing grasped nothing (its
        tool lies elsewhere: on the desk, in a basket, on a bench).
        """
        f = self.team.fetch_of_agent(agent)
        a = self.state.activities[f]
        if a is not None:
            grasped = a.kind == "search" and a.ok and a.progress >= 2
            holding = self._holding[f]
            tool = holding if holding >= 0 else (a.arg if grasped else -1)
            if tool >= 0:
                self._release(f, None)
                slot = (
                    self._desk_slot(f, self._slot_of[tool])
                    if a.kind == "pass"
                    else self.team.shelf_slot(tool)
                )
                self.scene.place(TOOL.format(tool), self._sites[slot])
        self.state.activities[f] = None

    def command_arm(self, agent: int) -> None:
        """This tick's arm set-points for the current activity (keyframes per tick)."""
        f = self.team.fetch_of_agent(agent)
        a, arm = self.state.activities[f], self.arms[f]
        if a is None or a.kind == "wait":
            arm.hold()
            return
        arm.set_arm_targets(arm.ik(self._arm_keyframe(f, a)))

    # --------------------------------------------------------------- internals
    def _desk_slot(self, f: int, k: int) -> str:
        return f"{self.team.desk(f)}/slot{k}"

    def _search_finds(self, f: int, tool: int) -> bool:
        """A search for ``tool`` now would stage it: not found yet, and the desk has room."""
        s = self.state
        return not s.found[tool] and len(s.desks[f]) < self.config.max_staged

    def _arm_keyframe(self, f: int, a: Activity) -> np.ndarray:
        """Where Fetch ``f``'s gripper should be during tick ``a.progress + 1`` of the activity.

        A search: above the shelf slot, down (grasp), up, above a free desk slot, down
        (release), up. A pass: down on the oldest staged tool (grasp), over the Turtlebot's
        basket, down (release), back up. A failed pass reaches out empty-handed, or brings a
        grasped tool back to its desk slot.
        """
        lift = np.array([0.0, 0.0, 0.15])
        if a.kind == "search":
            shelf = self._sites[self.team.shelf_slot(a.arg)]
            desk = self._sites[self._desk_slot(f, self._slot_for_search(f))]
            return (shelf + lift, shelf, shelf + lift, desk + lift, desk, desk + lift)[a.progress]
        desk = self._sites[self._desk_slot(f, self._slot_of.get(a.tool, 0))]
        basket = self.scene.site_position(f"{self.team.agents[a.arg]}/load")
        if not a.ok:  # reach over the desk spot, wherever the Turtlebot actually is
            basket[:2] = self.team.desk_spot(f, a.arg)
        if not a.ok and a.progress >= 1 and a.tool >= 0 and self._holding[f] == a.tool:
            return desk  # take the tool back to where it was
        return (desk, basket + lift, basket + lift * 0.3, desk + lift)[a.progress]

    def _slot_for_search(self, f: int) -> int:
        """The free desk slot a found tool goes to (slot 0 for a search that finds nothing)."""
        used = {self._slot_of[j] for j in self.state.desks[f]}
        return min(set(range(self.config.max_staged)) - used, default=0)

    def _advance_activity(self, f: int) -> float:
        """Advance Fetch ``f``'s activity one tick; grasps, releases, and the pass rules."""
        s, c, a = self.state, self.config, self.state.activities[f]
        if a is None:
            return 0.0
        reward = 0.0
        if a.kind == "pass" and a.progress == 0:
            # Judged once every agent has started this tick's options, so a Turtlebot that
            # re-chooses GetTool at the same decision point still counts as waiting.
            a.ok = self.ready_for_pass(f, a.arg)
            reward += 0.0 if a.ok else c.failed_pass_reward
        elif a.kind == "pass" and a.ok and s.getting_tool[a.arg] != f:
            a.ok = False  # the Turtlebot stopped waiting before the pass ended
            reward += c.failed_pass_reward
        a.progress += 1
        if a.kind == "search" and a.ok:
            if a.progress == 2:
                self._grasp(f, a.arg)
            elif a.progress == 5:
                self._slot_of[a.arg] = self._slot_for_search(f)
                self._release(f, None)
        elif a.kind == "pass" and a.tool >= 0:
            if a.progress == 1 and a.ok:
                self._grasp(f, a.tool)
            elif a.progress == 3 and self._holding[f] == a.tool:
                self._release(f, BASKET.format(self.team.agents[a.arg]) if a.ok else None)
        if a.progress < a.duration:
            return reward
        if a.kind == "search" and a.ok:
            s.found[a.arg] = True
            s.desks[f].append(a.arg)
        elif a.kind == "pass" and a.ok and a.tool >= 0:
            s.desks[f].remove(a.tool)
            s.carried[a.arg].append(a.tool)
            s.received[a.arg] = True
        s.activities[f] = None
        return reward

    def _grasp(self, f: int, tool: int) -> None:
        arm = self.arms[f]
        arm.set_gripper(True)
        self.scene.attach(TOOL.format(tool), arm.gripper_body)
        self._holding[f] = tool

    def _release(self, f: int, holder: str | None) -> None:
        self.arms[f].set_gripper(False)
        if self._holding[f] >= 0:
            self.scene.attach(TOOL.format(self._holding[f]), holder)
        self._holding[f] = -1

    def _deliver(self) -> float:
        """Hand every human the tool it needs now, if a Turtlebot at its workshop carries it
        (one delivery per human and tick)."""
        s, c, team = self.state, self.config, self.team
        reward = 0.0
        for h, workshop in enumerate(team.workshops):
            if s.stages[h] >= NUM_TOOLS:
                continue
            needed = team.tool(h, s.stages[h])
            if s.delivered[needed]:
                continue
            for w in team.turtlebot_ids:
                if needed in s.carried[w] and self.arrived(w, workshop):
                    s.carried[w].remove(needed)
                    s.delivered[needed] = True
                    # The human takes the tool off the basket onto the workbench.
                    self.scene.place(TOOL.format(needed), self._sites[team.bench_slot(needed)])
                    reward += c.delivery_reward
                    break
        return reward

    def _advance_human(self, h: int) -> None:
        s = self.state
        stage = s.stages[h]
        if stage >= NUM_TOOLS:
            return
        timer_over = self._ticks - s.stage_starts[h] >= self.config.human_stage_ticks
        if s.delivered[self.team.tool(h, stage)] and timer_over:
            s.stages[h] += 1
            s.stage_starts[h] = self._ticks
            self._show_stage(h)

    def _show_stage(self, h: int) -> None:
        """Light human ``h``'s progress bar up to its stage (visible in renders)."""
        for k in range(NUM_STAGES):
            lit = k <= self.state.stages[h]
            self.scene.set_geom_rgba(
                f"{self.team.human(h)}/stage{k}", STAGE_ON if lit else STAGE_OFF
            )

    # --------------------------------------------------------------- observations
    def observe(self, agent: int) -> np.ndarray:
        s, team = self.state, self.team
        counts = [min(len(desk), MAX_STAGED_SEEN) for desk in s.desks]
        if agent >= team.turtlebots:
            f = team.fetch_of_agent(agent)
            layout = team.fetch_layout
            obs = layout.zeros()
            obs[layout["staged"]][counts[f]] = 1.0
            obs[layout["waiting"]] = [self.ready_for_pass(f, w) for w in team.turtlebot_ids]
            return obs
        layout = team.turtlebot_layout
        obs = layout.zeros()
        spots = [
            *(("workshop", h, xy) for h, xy in enumerate(team.workshops)),
            *(("tool_room", f, xy) for f, xy in enumerate(team.wait_spots)),
            *(("desk", f, team.desk_spot(f, agent)) for f in team.fetch_ids),
        ]
        kind, i = next(((k, i) for k, i, xy in spots if self.arrived(agent, xy)), ("moving", 0))
        obs[layout["location"]][team.location(kind, i)] = 1.0
        if kind == "workshop":  # the human's stage is visible at its workshop, the desks not
            obs[layout["human_stage"]][s.stages[i]] = 1.0
        else:
            staged = obs[layout["staged"]]
            for f, count in enumerate(counts):
                staged[(MAX_STAGED_SEEN + 1) * f + count] = 1.0
        obs[layout["carried"]][s.carried[agent]] = 1.0
        return obs

    def labels(self) -> list[tuple[str, np.ndarray]]:
        """The robots, and each human by name at its workshop."""
        xpos = self.scene.data.xpos
        humans = [
            (self.team.human(h), xpos[body].copy()) for h, body in enumerate(self._human_bodies)
        ]
        return super().labels() + humans

    def describe(self) -> dict[str, object]:
        """The state for logs and the video panel: ``human_stage`` (an int, or one per human),
        ``staged`` (the desk's FIFO, or one per Fetch), ``carried`` (per Turtlebot) and
        ``delivered`` (per tool ``3h + j``)."""
        s, team = self.state, self.team
        return {
            "human_stage": s.stage if team.humans == 1 else list(s.stages),
            "staged": list(s.staged) if team.fetches == 1 else [list(d) for d in s.desks],
            "carried": [list(c) for c in s.carried],
            "delivered": list(s.delivered),
        }
