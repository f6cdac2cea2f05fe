"""The rules of the canonical macro-action Box Pushing grid, tick by tick, in pure Python.

A re-implementation, from the published description of the canonical environment, of the
grid the ACAC paper (ICML 2025; code: LGAI-Research/acac, ``acac/env/box_pushing_env``)
benchmarks on — ``BP-MA-v0``, itself MacroMARL's (Xiao, Hoffman, Amato, CoRL 2019) — and of
its primitive-action twin ``BP-v0``, which the published MAPPO curve used. One
:meth:`GridWorld.step` is one primitive env step of the canonical env; the option layer above
it (:mod:`~maopg.tasks.box_pushing_grid.task`) decides who issues what. The canonical scripted
episode, tick by tick, is ``tests/data/box_pushing_scripted_trace_6x6.csv``.

Geometry. Continuous coordinates on ``[0, n] x [0, n]``, cell centres at ``k + 0.5``, x east,
y north; orientations 0..3 = N, E, S, W. Two small boxes and a big box (centre x an integer,
covering the cells ``x - 0.5`` and ``x + 0.5``) sit in row ``n/2 + 0.5``; each box is served by
the waypoint right below it (two for the big box, one per half); a box whose centre reaches the
top row ``n - 0.5`` is delivered, which pays its reward and ends the episode.

Macro-actions (every one takes at least one tick and starts on the tick it is issued):

- ``GoToSmallBox(0|1)``, ``GoToBigBox(left|right)``: greedy one-step navigation with turn
  costs (no path search): each tick the neighbour (N, E, S, W order, first wins ties) of least
  Manhattan distance to the waypoint plus turn cost (0 ahead, 0.1 to the side, 0.2 behind) is
  chosen; ahead: move one cell, to the side: turn to it, behind: turn clockwise. It ends on the
  waypoint facing north and *records* that waypoint. Already on it: turn north at once (1 tick).
- ``Push``: walk ahead every tick until a wall (no penalty), or push a small box north until it
  is delivered. Penalties: facing a wall on the border (no move), moving into a box from any
  side but below (moved back), moving into the big box alone (moved back); each ends the Push.
- ``TurnLeft``, ``TurnRight``, ``Stay``: one tick, never penalised.

Joint big-box push: at the start of a tick, two agents whose macro-actions are done, who both
issue Push, both face north and whose *recorded* waypoints are the big box's two, start pushing
it: from that tick on each moves north every tick with the box (no per-agent rule runs, so no
penalties) until it is delivered, when both become done.

Observation (5 bits about the cell in front): small box, big box, empty, wall (the agent is on
the border facing out), teammate. An agent's bits are refreshed at the end of every tick on which
its macro-action is done, and otherwise repeated unchanged.

Reward per tick: ``step_reward`` + every penalty incurred this tick + the reward of every box on
the goal row (rewards add when several arrive together).

Quirks of the canonical env, reproduced on purpose (each changes what a policy can learn):

- **Agents never block each other**: navigation ignores the teammate and Push walks through it;
  agents may share a cell. Walls are ignored by navigation too (a GoTo started above the box
  row walks one column outside the grid before it comes back).
- **Navigation blocks the wrong cells once a box has moved**: a neighbour is blocked when its y
  is small box 0's *current* y and its x one of the boxes' columns, so while small box 0 is
  being pushed an agent may walk through a real box cell.
- **The joint push reads the recorded waypoint, not the position**: the waypoint a GoTo last
  reached is never cleared, so an agent that walked away from it and came back facing north in
  any column still qualifies (it then moves north through whatever is in its column, a small box
  included, without moving it).
- **A big-box push cannot be stopped**: once started, the pushers are carried north every tick
  whatever they issue, until delivery (the canonical flag is never cleared).
- **The observation lags**: an agent in the middle of a macro-action (a Push walking across the
  grid, a big-box push) keeps seeing what it saw when its previous one ended. The reset
  observation is what each agent sees in front at its start (the canonical env hard-codes
  ``00100`` — and ``00001`` for agent 0 on 4x4 with three agents —, which is exactly that at
  every start layout).
- **Penalties add up**: two agents penalised on one tick cost twice the penalty.

The primitive twin (:meth:`GridWorld.step_primitive`, actions MoveForward / TurnLeft /
TurnRight / Stay, one tick each, every observation fresh every tick) has the canonical
``BP-v0``'s own rules: MoveForward off the grid or into a box from any side but below is undone
with the penalty; two agents right below the two halves of the big box, facing north, both
moving forward, push it one row; and, as there, a pusher's flag is never cleared: from its first
joint push on, an agent moves north every tick whatever it chooses, so a team that does not push
again on every following tick walks its pushers off the top of the grid.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from maopg.tasks.box_pushing_grid.config import Config
from maopg.tasks.layout import ObsLayout

NORTH, EAST, SOUTH, WEST = range(4)
ORIENTATIONS = "NESW"
DIRECTIONS = ((0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0))
BOX_NAMES = ("small box 0", "small box 1", "big box")
"""The boxes in the order of ``GridWorld.boxes`` (and of Box Pushing's MuJoCo bodies)."""

MACROS = (
    "GoToSmallBox(0)",
    "GoToSmallBox(1)",
    "GoToBigBox(left)",
    "GoToBigBox(right)",
    "Push",
    "TurnLeft",
    "TurnRight",
    "Stay",
)
"""The macro-actions, in the canonical env's index order (a GoTo's index is its waypoint's)."""
PUSH, TURN_LEFT, TURN_RIGHT, STAY = 4, 5, 6, 7
BIG_BOX_SPOTS = frozenset({2, 3})
"""The waypoints below the big box's left and right halves."""

PRIMITIVES = ("MoveForward", "TurnLeft", "TurnRight", "Stay")
"""The primitive actions of the canonical ``BP-v0``, in its index order."""
FORWARD, PRIMITIVE_TURN_LEFT, PRIMITIVE_TURN_RIGHT, PRIMITIVE_STAY = range(4)

RUNNING = -1
"""The action given for an agent whose macro-action is still running (as the ACAC runner)."""

OBSERVATION = ("small_box", "big_box", "empty", "wall", "teammate")
"""The observation's bits, in order."""
LAYOUT = ObsLayout.of(**dict.fromkeys(OBSERVATION, 1))
"""An agent's observation vector: one named bit per field."""


def agent_names(count: int) -> tuple[str, ...]:
    """The agents' names, in index order: ``agent0``, ``agent1``, ..."""
    return tuple(f"agent{i}" for i in range(count))


@dataclass(frozen=True)
class Layout:
    """Where everything starts on a grid of side ``size`` (reference §2)."""

    size: int
    starts: tuple[tuple[float, float, int], ...]
    """Each agent's ``(x, y, orientation)``."""
    small_boxes: tuple[tuple[float, float], tuple[float, float]]
    big_box: tuple[float, float]
    """Centre: x an integer between the box's two cells."""
    waypoints: tuple[tuple[float, float], ...]
    """Below small box 0, small box 1, the big box's left half, its right half."""

    @classmethod
    def of(cls, size: int, agents: int = 2) -> Layout:
        """The canonical layout: small boxes and agents one column in from the sides from 8x8
        up (in the outer columns below), agents in the second row (the first on 4x4), the
        third agent left of the middle facing north."""
        n = float(size)
        side = 0.5 if size <= 6 else 1.5
        row = 0.5 if size == 4 else 1.5
        box_y, spot_y = n / 2 + 0.5, n / 2 - 0.5
        starts = [(side, row, EAST), (n - side, row, WEST), (n / 2 - 0.5, row, NORTH)]
        return cls(
            size=size,
            starts=tuple(starts[:agents]),
            small_boxes=((side, box_y), (n - side, box_y)),
            big_box=(n / 2, box_y),
            waypoints=(
                (side, spot_y),
                (n - side, spot_y),
                (n / 2 - 0.5, spot_y),
                (n / 2 + 0.5, spot_y),
            ),
        )

    @property
    def goal_y(self) -> float:
        """The goal row: the top one."""
        return self.size - 0.5


@dataclass(slots=True)
class Agent:
    x: float
    y: float
    ori: int
    macro: int = -1
    """Its current (or last) macro-action (or primitive action), ``-1`` before the first."""
    done: bool = True
    """Its macro-action has ended: it takes a new one on its next tick."""
    waypoint: int = -1
    """The waypoint its last finished GoTo reached (never cleared; ``-1``: none yet)."""
    pushing: bool = False
    """Committed to the big box (never cleared, see the module docstring)."""

    def facing_out(self, size: int) -> bool:
        """On the border cell in its facing direction."""
        edge = size - 0.5
        return (self.y == edge, self.x == edge, self.y == 0.5, self.x == 0.5)[self.ori]


@dataclass(slots=True)
class Box:
    x: float
    y: float
    big: bool

    def covers(self, x: float, y: float) -> bool:
        """The cell centred at ``(x, y)`` is (one of) this box's."""
        return y == self.y and (x == self.x or abs(x - self.x) == 0.5)


class GridWorld:
    """Agents, boxes and the canonical rules (see the module docstring)."""

    def __init__(self, config: Config) -> None:
        self.config = config
        self.layout = Layout.of(config.size, config.agents)
        self.reset()

    def reset(self) -> None:
        layout = self.layout
        self.agents = [Agent(x, y, ori) for x, y, ori in layout.starts]
        self.boxes = [Box(x, y, False) for x, y in layout.small_boxes]
        self.boxes.append(Box(*layout.big_box, True))
        self.ticks = 0
        self.pushing_big_box = False
        self.issued: tuple[int, ...] = (RUNNING,) * len(self.agents)
        """The actions of the last tick (``-1``: the agent's macro-action ran on)."""
        self.observations = [self.observe(i) for i in range(len(self.agents))]

    # ----------------------------------------------------------------- the two kinds of tick
    def step(self, actions: Sequence[int]) -> float:
        """One tick of the macro-action env: ``actions[i]`` is the macro-action agent ``i``
        issues, read only if its previous one is done (``-1`` otherwise). Returns the reward."""
        c, agents = self.config, self.agents
        self._check(actions, len(MACROS))
        self.issued = tuple(actions)
        reward = c.step_reward
        for a, b in itertools.combinations(range(len(agents)), 2):
            if self._joint_push(actions, a, b):
                agents[a].pushing = agents[b].pushing = self.pushing_big_box = True
        for i, agent in enumerate(agents):
            if agent.pushing:
                agent.macro, agent.done = PUSH, False
                agent.y += 1.0
            else:
                reward += self._run(agent, agent.macro if not agent.done else actions[i])
        big = self.boxes[2]
        if self.pushing_big_box:
            big.y += 1.0
            if big.y == self.layout.goal_y:
                for agent in agents:
                    agent.done = agent.done or agent.pushing
        return self._end_tick(reward)

    def step_primitive(self, actions: Sequence[int]) -> float:
        """One tick of the primitive-action twin (``BP-v0``); every agent acts. Returns the
        reward."""
        c, agents = self.config, self.agents
        self._check(actions, len(PRIMITIVES))
        self.issued = tuple(actions)
        reward = c.step_reward
        self.pushing_big_box = False
        big = self.boxes[2]
        for a, b in itertools.combinations(range(len(agents)), 2):
            first, second = agents[a], agents[b]
            below = {(first.x - big.x, first.y), (second.x - big.x, second.y)}
            if (
                actions[a] == actions[b] == FORWARD
                and first.ori == second.ori == NORTH
                and below == {(-0.5, big.y - 1.0), (0.5, big.y - 1.0)}
            ):
                first.pushing = second.pushing = self.pushing_big_box = True
        for agent, action in zip(agents, actions, strict=True):
            agent.macro = FORWARD if agent.pushing else action
            if agent.pushing:
                agent.y += 1.0
            else:
                reward += self._primitive(agent, action)
        if self.pushing_big_box:
            big.y += 1.0
        for agent in agents:
            agent.done = True
        return self._end_tick(reward)

    def _check(self, actions: Sequence[int], count: int) -> None:
        if len(actions) != len(self.agents):
            raise ValueError(f"expected {len(self.agents)} actions, got {list(actions)}")
        for i, (agent, action) in enumerate(zip(self.agents, actions, strict=True)):
            valid = range(count) if agent.done else range(RUNNING, count)
            if action not in valid:
                raise ValueError(
                    f"agent {i}'s action must be in {valid.start}..{count - 1} "
                    f"({'its macro-action has ended' if agent.done else 'still running'}), "
                    f"got {action}"
                )

    def _end_tick(self, reward: float) -> float:
        """Box rewards, then the observations of the agents whose macro-action is done."""
        c = self.config
        goal = self.layout.goal_y
        for box in self.boxes:
            if box.y == goal:
                reward += c.big_box_reward if box.big else c.small_box_reward
        for i, agent in enumerate(self.agents):
            if agent.done:
                self.observations[i] = self.observe(i)
        self.ticks += 1
        return reward

    def end_macro(self, i: int) -> None:
        """Cut agent ``i``'s macro-action short (the ``any`` strategy): it is done now, as if
        the macro-action had ended on the last tick, and sees what is in front of it. A
        big-box push goes on regardless (the pushers are carried with the box)."""
        self.agents[i].done = True
        self.observations[i] = self.observe(i)

    # ----------------------------------------------------------------- macro-actions
    def _joint_push(self, actions: Sequence[int], a: int, b: int) -> bool:
        first, second = self.agents[a], self.agents[b]
        return (
            actions[a] == actions[b] == PUSH
            and first.done
            and second.done
            and first.ori == second.ori == NORTH
            and {first.waypoint, second.waypoint} == BIG_BOX_SPOTS
        )

    def _run(self, agent: Agent, macro: int) -> float:
        """One tick of ``macro`` (started now, or running on); returns its penalty."""
        agent.macro, agent.done = macro, False
        if macro < PUSH:
            self._navigate(agent, macro)
            return 0.0
        if macro == PUSH:
            return self._push(agent)
        if macro == TURN_LEFT:
            agent.ori = (agent.ori - 1) % 4
        elif macro == TURN_RIGHT:
            agent.ori = (agent.ori + 1) % 4
        agent.done = True
        return 0.0

    def _navigate(self, agent: Agent, waypoint: int) -> None:
        """One tick of a GoTo: move or turn greedily (see the module docstring)."""
        wx, wy = self.layout.waypoints[waypoint]
        if (wx - agent.x) ** 2 + (wy - agent.y) ** 2 < 0.01:
            agent.ori, agent.waypoint, agent.done = NORTH, waypoint, True
            return
        small0, small1, big = self.boxes
        blocked_xs = (small0.x, small1.x, big.x + 0.5, big.x - 0.5)

        def cost(d: int) -> tuple[float, int, int]:
            x, y = agent.x + DIRECTIONS[d][0], agent.y + DIRECTIONS[d][1]
            blocked = y == small0.y and x in blocked_xs
            turn = (d - agent.ori) % 4
            return (float("inf") if blocked else abs(wx - x) + abs(wy - y), min(turn, 4 - turn), d)

        _, turn, d = min(cost(d) for d in range(4))
        if turn == 0:
            agent.x += DIRECTIONS[d][0]
            agent.y += DIRECTIONS[d][1]
        elif turn == 2:
            agent.ori = (agent.ori + 1) % 4
        else:
            agent.ori = d
        if agent.x == wx and agent.y == wy and agent.ori == NORTH:
            agent.waypoint, agent.done = waypoint, True

    def _push(self, agent: Agent) -> float:
        """One tick of Push (see the module docstring)."""
        size, penalty = self.layout.size, self.config.penalty
        if agent.facing_out(size):
            agent.done = True
            return penalty
        reward, pushed = 0.0, False
        dx, dy = DIRECTIONS[agent.ori]
        agent.x += dx
        agent.y += dy
        for box in self.boxes:  # in index order, against where the agent stands by then
            if not box.covers(agent.x, agent.y):
                continue
            if agent.ori == NORTH and not box.big:
                pushed = True
                box.y += dy
                agent.done = agent.done or box.y == self.layout.goal_y
            else:
                agent.x -= dx
                agent.y -= dy
                agent.done = True
                reward += penalty
        if not pushed and agent.facing_out(size):
            agent.done = True
        return reward

    # ----------------------------------------------------------------- primitive actions
    def _primitive(self, agent: Agent, action: int) -> float:
        """One primitive action of an agent not pushing the big box; returns its penalty."""
        penalty, reward = self.config.penalty, 0.0
        if action == PRIMITIVE_TURN_LEFT:
            agent.ori = (agent.ori - 1) % 4
        elif action == PRIMITIVE_TURN_RIGHT:
            agent.ori = (agent.ori + 1) % 4
        if action != FORWARD:
            return reward
        dx, dy = DIRECTIONS[agent.ori]
        agent.x += dx
        agent.y += dy
        edge = self.layout.size - 0.5
        if not (0.5 <= agent.x <= edge and 0.5 <= agent.y <= edge):
            agent.x -= dx
            agent.y -= dy
            reward += penalty
        for box in self.boxes:
            if not box.covers(agent.x, agent.y):
                continue
            if agent.ori == NORTH and not box.big:
                box.y += dy
            else:
                agent.x -= dx
                agent.y -= dy
                reward += penalty
        return reward

    # ----------------------------------------------------------------- what is seen
    def observe(self, i: int) -> np.ndarray:
        """Agent ``i``'s bits about the cell in front of it now (float32, :data:`OBSERVATION`
        order)."""
        agent, n = self.agents[i], self.layout.size
        x, y = agent.x + DIRECTIONS[agent.ori][0], agent.y + DIRECTIONS[agent.ori][1]
        small0, small1, big_box = self.boxes
        small = any(b.x == x and b.y == y for b in (small0, small1))
        big = big_box.y == y and abs(x - big_box.x) == 0.5
        wall = not (0.0 <= x <= n and 0.0 <= y <= n)
        mate = any(o.x == x and o.y == y for k, o in enumerate(self.agents) if k != i)
        bits = (small, big, not (small or big or wall or mate), wall, mate)
        return np.array(bits, dtype=np.float32)

    def state(self) -> np.ndarray:
        """The canonical global state (:func:`state_vector`)."""
        return state_vector(
            [(a.x, a.y, a.ori) for a in self.agents],
            [(b.x, b.y) for b in self.boxes],
            self.layout.size,
        )

    def delivered(self) -> tuple[bool, bool, bool]:
        """Whether small box 0, small box 1 and the big box are on the goal row."""
        goal = self.layout.goal_y
        small0, small1, big = (box.y == goal for box in self.boxes)
        return small0, small1, big

    def terminated(self) -> bool:
        """A box has been delivered (every delivery ends the episode)."""
        return any(self.delivered())


def state_vector(
    agents: Sequence[tuple[float, float, int]], boxes: Sequence[tuple[float, float]], size: int
) -> np.ndarray:
    """The canonical global state (``get_state``): per agent ``x/n, y/n`` (cells) and a one-hot
    orientation (N, E, S, W), then ``x/n, y/n`` of small box 0, small box 1 and the big box
    (its centre): 18 floats for two agents. The grid's and the MuJoCo task's, alike."""
    n = float(size)
    values: list[float] = []
    for x, y, ori in agents:
        values += [x / n, y / n, *(float(ori == o) for o in range(4))]
    for x, y in boxes:
        values += [x / n, y / n]
    return np.array(values, dtype=np.float32)
