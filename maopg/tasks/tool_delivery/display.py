"""How Tool Delivery's state reads in the video panel, at any team size."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from maopg.tasks.panel import Field, Gauge, Heading, PanelItem
from maopg.tasks.tool_delivery.constants import NUM_TOOLS


def tools(indices: Sequence[int]) -> str:
    """``tool 0, tool 2``, or ``nothing``."""
    return ", ".join(f"tool {int(t)}" for t in indices) or "nothing"


def panel(state: Mapping[str, Any]) -> list[PanelItem]:
    """Each human's progress through its tools as a bar and the tool it needs, what lies on
    each desk, what each Turtlebot carries and which tools were delivered (from
    ``ToolDelivery.describe()``, whose ``human_stage`` and ``staged`` are one value each for
    one human / one Fetch and lists of them for several)."""
    several_humans = isinstance(state["human_stage"], list)
    stages = list(state["human_stage"]) if several_humans else [state["human_stage"]]
    staged = list(state["staged"])
    desks = staged if staged and isinstance(staged[0], list) else [staged]
    items: list[PanelItem] = [Heading("humans: tools received")]
    for h, stage in enumerate(int(s) for s in stages):
        needs = f"needs tool {h * NUM_TOOLS + stage}" if stage < NUM_TOOLS else "all tools in"
        name = f"human {h}" if several_humans else "human"
        items.append(Gauge(name, stage / NUM_TOOLS, f"{stage}/{NUM_TOOLS}, {needs}"))
    items.append(Heading("who carries what"))
    for w, carried in enumerate(state["carried"]):
        items.append(Field(f"turtlebot{w}", tools(carried)))
    for f, desk in enumerate(desks):
        items.append(Field(f"desk {f}" if len(desks) > 1 else "desk", tools(desk)))
    delivered = [t for t, d in enumerate(state["delivered"]) if d]
    return [*items, Field("delivered", tools(delivered) if delivered else "none yet")]
