"""How Tool Delivery's state reads in the video panel, at any team size."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from maopg.tasks.text import format_value
from maopg.tasks.tool_delivery.constants import NUM_TOOLS


def state_lines(state: Mapping[str, Any]) -> list[str]:
    """Which tool each human needs, where the tools are (from ``ToolDelivery.describe()``,
    whose ``human_stage`` and ``staged`` are one value each for one human / one Fetch and
    lists of them for several)."""
    several_humans = isinstance(state["human_stage"], list)
    stages = list(state["human_stage"]) if several_humans else [state["human_stage"]]
    staged = list(state["staged"])
    desks = staged if staged and isinstance(staged[0], list) else [staged]
    lines = []
    for h, stage in enumerate(int(s) for s in stages):
        needs = f"needs tool {stage}" if stage < NUM_TOOLS else "all tools in"
        lines.append(f"human{f' {h}' if several_humans else ''} stage {stage} ({needs})")
    for f, desk in enumerate(desks):
        lines.append(f"staged on desk{f' {f}' if len(desks) > 1 else ''}: {format_value(desk)}")
    for w, carried in enumerate(state["carried"]):
        lines.append(f"turtlebot{w} carries: {format_value(list(carried))}")
    delivered = (f"t{t}={'yes' if d else 'no'}" for t, d in enumerate(state["delivered"]))
    return [*lines, "delivered: " + " ".join(delivered)]
