"""How Tool Delivery's state reads in the video panel."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from maopg.tasks.text import format_value
from maopg.tasks.tool_delivery.constants import AGENTS, TURTLEBOTS


def state_lines(state: Mapping[str, Any]) -> list[str]:
    """Which tool the human needs, where the tools are (from ``ToolDelivery.describe()``)."""
    stage = int(state["human_stage"])
    delivered = list(state["delivered"])
    needs = f"needs tool {stage}" if stage < len(delivered) else "all tools in"
    carried = list(state["carried"])
    return [
        f"human stage {stage} ({needs})",
        f"staged on desk: {format_value(list(state['staged']))}",
        *(f"{AGENTS[w]} carries: {format_value(list(carried[w]))}" for w in TURTLEBOTS),
        "delivered: " + " ".join(f"t{j}={'yes' if d else 'no'}" for j, d in enumerate(delivered)),
    ]
