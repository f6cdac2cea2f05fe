"""Box Pushing's option sets: the canonical macro-actions, or ``BP-v0``'s primitive actions.

An option here only *issues* its action to the grid: the grid's macro-actions keep no state of
their own and are re-evaluated from the positions every tick
(:class:`~maopg.tasks.box_pushing_grid.world.GridWorld`), so the grid runs them on by itself and
says when each has ended.
"""

from __future__ import annotations

from typing import Protocol

from maopg.options.base import AgentControl, Execution, Option
from maopg.tasks.box_pushing_grid.config import Config
from maopg.tasks.box_pushing_grid.world import MACROS, PRIMITIVES


class GridRules(AgentControl, Protocol):
    """What a grid action asks of the task."""

    def issue(self, agent: int, action: int) -> None:
        """The agent issues ``action`` on its next tick (its previous action has ended)."""

    def action_done(self, agent: int) -> bool:
        """The agent's action ended on the last tick."""

    def end_action(self, agent: int) -> None:
        """Cut the agent's running action short (the ``any`` strategy): it issues a new one on
        its next tick, as if the running one had ended."""


class GridAction(Option[GridRules]):
    """Action ``index`` of the canonical env: issued when chosen, run on by the grid."""

    def __init__(self, name: str, index: int) -> None:
        self.name, self.index = name, index

    def start(self, task: GridRules, ex: Execution) -> None:
        task.issue(ex.agent, self.index)

    def step(self, task: GridRules, ex: Execution) -> None:
        """Nothing to command: the grid advances a running action itself."""

    def done(self, task: GridRules, ex: Execution) -> bool:
        return task.action_done(ex.agent)

    def interrupt(self, task: GridRules, ex: Execution) -> None:
        task.end_action(ex.agent)


def option_set(config: Config) -> tuple[GridAction, ...]:
    """Every agent's actions, in the canonical index order: the 8 macro-actions, or the 4
    primitive ones when ``config.primitive``."""
    names = PRIMITIVES if config.primitive else MACROS
    return tuple(GridAction(name, k) for k, name in enumerate(names))
