"""Box Pushing on a grid: the field's standard macro-action benchmark, exactly as the reference
defines it, as a task of this project (no MuJoCo scene: the rules are
:mod:`~maopg.tasks.box_pushing_grid.world`'s, whose docstring lists them and their quirks).

Two agents (three with ``agents=3``) on an ``n x n`` grid (``size`` 4, 6, 8 or 10) bring a box
to the top row: a small one alone (+20) or the big one together (+300); −0.1 per tick, −10 per
penalised Push; the first delivery ends the episode (a termination), ``max_ticks`` (100) cuts
it (a truncation, bootstrapped). ``solved`` means the big box was delivered.

One tick is one primitive step of the canonical env. Each agent's options are the eight
macro-actions; an agent chooses when its own macro-action ends (``continue``, the canonical
protocol), and its observation — the 5 bits about the cell in front — is refreshed exactly then.
A centralized policy reads the joint observation (every agent's bits). The canonical global
state (18 floats for two agents: positions, orientations, boxes) is :meth:`BoxPushingGrid.state`
for critics that take one; no policy sees it.

The other strategies, and what they mean here:

- ``any`` (sync-cut): every running macro-action is cut when one ends; the cut agent is done at
  once (:meth:`~maopg.tasks.box_pushing_grid.world.GridWorld.end_macro`: it sees afresh and takes
  part in a joint push if it qualifies). The macro-actions keep no state, so choosing the same
  one again carries on exactly where it was; only a big-box push cannot be cut — its pushers are
  carried north with the box until delivery, whatever they choose meanwhile.
- ``all`` (sync-wait): an agent whose macro-action ended does ``Stay`` (no move, no penalty, and
  its observation stays fresh) until every agent's has ended.
- ``primitive`` (end2end): the canonical primitive-action twin ``BP-v0`` (MoveForward,
  TurnLeft, TurnRight, Stay; the published MAPPO curve's environment), with its own rules
  (world docstring).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from maopg.options.base import Option
from maopg.tasks.base import Task
from maopg.tasks.box_pushing_grid.config import Config
from maopg.tasks.box_pushing_grid.display import draw
from maopg.tasks.box_pushing_grid.options import option_set
from maopg.tasks.box_pushing_grid.world import (
    BOX_NAMES,
    LAYOUT,
    ORIENTATIONS,
    PRIMITIVE_STAY,
    RUNNING,
    STAY,
    GridWorld,
    agent_names,
)
from maopg.tasks.layout import ObsLayout

WAYPOINTS = ("small box 0", "small box 1", "big box left", "big box right")
"""What each waypoint serves, in index order."""


class BoxPushingGrid(Task):
    """The grid, its agents and their macro-actions (see the module docstring).

    Implements :class:`~maopg.tasks.box_pushing_grid.options.GridRules`, the interface its
    options act through.
    """

    name = "box_pushing_grid"
    Config = Config
    tick_seconds = 1.0

    def __init__(self, config: Config | None = None) -> None:
        self.config = config = config or Config()
        if config.images:
            raise ValueError(
                f"images=true: task {self.name!r} has no cameras (its observations are 5 bits); "
                "run it with images=false"
            )
        self.world = GridWorld(config)
        self._options = option_set(config)
        self._stay = PRIMITIVE_STAY if config.primitive else STAY
        self._step = self.world.step_primitive if config.primitive else self.world.step
        self._issued = [RUNNING] * config.agents

    # ----------------------------------------------------------------- static description
    @property
    def agent_names(self) -> tuple[str, ...]:
        return agent_names(self.config.agents)

    def robot_of(self, agent: int) -> str:
        return "grid"

    def options(self, agent: int) -> Sequence[Option[Any]]:
        return self._options

    def observation_layout(self, agent: int) -> ObsLayout:
        return LAYOUT

    # ----------------------------------------------------------------- dynamics
    def reset(self, seed: int) -> None:
        # The canonical env is deterministic (its random starts are off in every published run);
        # the seed is accepted for the contract.
        del seed
        self.world.reset()
        self._issued = [RUNNING] * self.config.agents

    def issue(self, agent: int, action: int) -> None:
        self._issued[agent] = action

    def hold(self, agent: int) -> None:
        """Stay: no move, no penalty (an agent idling under ``all``)."""
        self._issued[agent] = self._stay

    def action_done(self, agent: int) -> bool:
        return self.world.agents[agent].done

    def end_action(self, agent: int) -> None:
        self.world.end_macro(agent)

    def tick(self) -> float:
        actions, self._issued = self._issued, [RUNNING] * self.config.agents
        return self._step(actions)

    @property
    def ticks(self) -> int:
        return self.world.ticks

    def terminated(self) -> bool:
        return self.world.terminated()

    def solved(self) -> bool:
        """The big box was delivered."""
        return self.world.delivered()[2]

    # ----------------------------------------------------------------- observations
    def observe(self, agent: int) -> np.ndarray:
        return self.world.observations[agent].copy()

    def global_state_size(self) -> int:
        """Per agent its position and a one-hot heading, then the three boxes' positions."""
        return 6 * len(self.agent_names) + 6

    def global_state(self) -> np.ndarray:
        """The canonical global state (float32; 18 values for two agents, 24 for three): for a
        critic that takes one. No policy reads it."""
        return self.world.state()

    def describe(self) -> dict[str, object]:
        """The state for logs and the video panel: each agent's ``positions`` and ``facing``,
        the waypoint its last GoTo ``reached`` (``-``: none; what a joint push checks), the
        boxes, and what has been ``delivered``."""
        world = self.world
        return {
            "size": world.layout.size,
            "positions": [(a.x, a.y) for a in world.agents],
            "facing": [ORIENTATIONS[a.ori] for a in world.agents],
            "reached": [WAYPOINTS[a.waypoint] if a.waypoint >= 0 else "-" for a in world.agents],
            "boxes": [(b.x, b.y) for b in world.boxes],
            "delivered": [name for name, d in zip(BOX_NAMES, world.delivered(), strict=True) if d],
        }

    def video_frame(self) -> np.ndarray:
        """A top-down drawing of the grid."""
        return draw(self.world)
