"""How Box Pushing reads in a video's panel (the overview camera shows the arena itself)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from maopg.tasks.box_pushing_grid.display import box_pushing_items
from maopg.tasks.panel import PanelItem


def panel(state: Mapping[str, Any]) -> list[PanelItem]:
    """The grid's panel (:func:`box_pushing_items`) with positions in cells of the arena: a
    box is delivered once its centre crosses the goal strip's southern edge, a row from the
    top (from ``BoxPushing.describe()``)."""
    return box_pushing_items(state, goal=state["size"] - 1.0)
