"""How Box Pushing reads in a video's panel (the overview camera shows the arena itself)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def state_lines(state: Mapping[str, Any]) -> list[str]:
    """Where the robots stand and face and where the boxes are, in cells, how far the big box
    has still to go, and what was delivered (from ``BoxPushing.describe()``)."""
    size = state["size"]
    lines = [f"{size}x{size} cells of {state['cell']:g} m, goal: top row"]
    for i, ((x, y), facing) in enumerate(zip(state["positions"], state["facing"], strict=True)):
        lines.append(f"agent{i} ({x:.2f}, {y:.2f}) facing {facing}")
    (s0x, s0y), (s1x, s1y), (bx, by) = state["boxes"]
    lines.append(f"small boxes ({s0x:.2f}, {s0y:.2f}) ({s1x:.2f}, {s1y:.2f})")
    lines.append(f"big box ({bx:.2f}, {by:.2f}), {state['to_goal']:.2f} cells to go")
    delivered = ", ".join(state["delivered"]) or "nothing yet"
    return [*lines, f"delivered: {delivered}"]
