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

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from maopg.options.base import Option
from maopg.tasks.base import SceneTask
from maopg.tasks.layout import ObsLayout
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import (
    AGENTS,
    BASKET,
    FETCH,
    FETCH_OBS,
    LOCATIONS,
    MAX_STAGED_SEEN,
    NUM_STAGES,
    NUM_TOOLS,
    STAGE_OFF,
    STAGE_ON,
    T0,
    T1,
    TOOL,
    TOOL_ROOM_WAIT,
    TURTLEBOT_OBS,
    TURTLEBOTS,
    WORKSHOP,
)
from maopg.tasks.tool_delivery.options import option_sets
from maopg.tasks.tool_delivery.scene import build_scene


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


class ToolDelivery(SceneTask):
    """Three robots, three tools, one human (see the module docstring).

    Implements :class:`~maopg.tasks.tool_delivery.options.DeliveryRules`, the interface its
    options act through.
    """

    name = "tool_delivery"
    Config = Config

    def __init__(self, config: Config | None = None) -> None:
        self.config = config = config or Config()
        self.tick_seconds = config.tick_seconds
        self.scene = build_scene(config)
        self.turtlebots = [self.scene.robots[AGENTS[w]] for w in TURTLEBOTS]
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
        self._options = option_sets(config)
        self.reset(0)

    # --------------------------------------------------------------- static description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return AGENTS

    def robot_of(self, agent: int) -> str:
        return self.config.fetch_robot if agent == FETCH else self.config.turtlebot_robot

    def options(self, agent: int) -> Sequence[Option[Any]]:
        return self._options[agent]

    def observation_layout(self, agent: int) -> ObsLayout:
        return FETCH_OBS if agent == FETCH else TURTLEBOT_OBS

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
        for w in TURTLEBOTS:
            s.at_desk[w] = s.getting_tool[w] and self.arrived(w, self.config.desk_spots[w])
            s.at_desk_ticks[w] += s.at_desk[w]
        reward += self._deliver()
        self._advance_human()
        return reward

    def terminated(self) -> bool:
        return self.state.delivered[NUM_TOOLS - 1]

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
    def begin_waiting(self, w: int, *, primitive: bool = False) -> None:
        s = self.state
        if primitive:
            s.getting_tool[w] = self.arrived(w, self.config.desk_spots[w])
        else:
            s.getting_tool[w] = True
            s.at_desk_ticks[w] = 0

    def waiting_over(self, w: int) -> bool:
        s = self.state
        return s.received[w] or s.at_desk_ticks[w] > self.config.max_wait_ticks

    def stop_waiting(self, w: int) -> None:
        self.state.getting_tool[w] = False

    def ready_for_pass(self, w: int) -> bool:
        """Turtlebot ``w`` waits for a tool and already ended the previous tick at its spot."""
        s = self.state
        return s.getting_tool[w] and s.at_desk[w]

    def activity_available(self, kind: str, arg: int) -> bool:
        """Everything is available in the canonical task (a pointless search or an empty pass
        just wastes ticks); ``mask_options`` masks those, as a user may prefer."""
        if not self.config.mask_options or self.continues(kind, arg):
            return True
        if kind == "pass":
            return bool(self.state.staged)
        if kind == "search":
            return self._search_finds(arg)
        return True

    def continues(self, kind: str, arg: int) -> bool:
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
            activity.ok = self._search_finds(arg)
        s.activity = activity

    def fetch_busy(self) -> bool:
        return self.state.activity is not None

    def abort_activity(self) -> None:
        """Drop an unfinished activity (interrupted, or replaced in primitive mode).

        A tool in the gripper goes back where the activity found it, so the bookkeeping
        (staged / found) and the scene agree. A search that finds nothing grasped nothing (its
        tool lies elsewhere: on the desk, in a basket, on a bench).
        """
        a = self.state.activity
        if a is not None:
            grasped = a.kind == "search" and a.ok and a.progress >= 2
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
    def _search_finds(self, j: int) -> bool:
        """A search for tool ``j`` now would stage it: not found yet, and the desk has room."""
        s = self.state
        return not s.found[j] and len(s.staged) < self.config.max_staged

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
            basket[:2] = self.config.desk_spots[a.arg]
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
                self._release(BASKET.format(AGENTS[a.arg]) if a.ok else None)
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
        self.scene.attach(TOOL.format(tool), self.fetch.gripper_body)
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
        for w in TURTLEBOTS:
            if needed in s.carried[w] and self.arrived(w, WORKSHOP):
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
        staged = min(len(s.staged), MAX_STAGED_SEEN)
        if agent == FETCH:
            obs = FETCH_OBS.zeros()
            obs[FETCH_OBS["staged"]][staged] = 1.0
            obs[FETCH_OBS["waiting"]] = [self.ready_for_pass(w) for w in (T0, T1)]
            return obs
        layout = TURTLEBOT_OBS
        obs = layout.zeros()
        spots = {
            "workshop": WORKSHOP,
            "tool_room": TOOL_ROOM_WAIT,
            "desk": self.config.desk_spots[agent],
        }
        where = next((p for p, xy in spots.items() if self.arrived(agent, xy)), "moving")
        obs[layout["location"]][LOCATIONS.index(where)] = 1.0
        if where == "workshop":  # the human's stage is visible at WA0, the desk is not
            obs[layout["human_stage"]][s.stage] = 1.0
        else:
            obs[layout["staged"]][staged] = 1.0
        obs[layout["carried"]][s.carried[agent]] = 1.0
        return obs

    def describe(self) -> dict[str, object]:
        s = self.state
        return {
            "human_stage": s.stage,
            "staged": list(s.staged),
            "carried": [list(c) for c in s.carried],
            "delivered": list(s.delivered),
        }
