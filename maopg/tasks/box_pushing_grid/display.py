"""How Box Pushing looks in a video: the panel's lines and a top-down drawing of the grid."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from maopg.tasks.box_pushing_grid.world import DIRECTIONS, GridWorld

SIDE = 480
"""Pixels a side of the drawing (the video's overview is 480 px high)."""
FLOOR, OUTSIDE, LINES = (232, 232, 224), (60, 60, 66), (170, 170, 170)
GOAL = (250, 226, 120)
SPOT = (178, 34, 34)
BOX, BOX_EDGE = (196, 140, 60), (110, 72, 20)
AGENT_COLOURS = ((40, 160, 70), (50, 90, 200), (140, 60, 190))
INK = (20, 20, 20)


def state_lines(state: Mapping[str, Any]) -> list[str]:
    """Where the agents stand and face, the waypoint each last reached (what a joint push
    checks), where the boxes are and what was delivered (from ``BoxPushingGrid.describe()``)."""
    lines = [f"{state['size']}x{state['size']} grid, goal: top row"]
    for i, ((x, y), facing, reached) in enumerate(
        zip(state["positions"], state["facing"], state["reached"], strict=True)
    ):
        lines.append(f"agent{i} ({x:g}, {y:g}) facing {facing}")
        lines.append(f"  reached: {reached}")
    (s0x, s0y), (s1x, s1y), (bx, by) = state["boxes"]
    lines.append(f"small boxes ({s0x:g}, {s0y:g}) ({s1x:g}, {s1y:g})")
    lines.append(f"big box ({bx:g}, {by:g})")
    delivered = ", ".join(state["delivered"]) or "nothing yet"
    return [*lines, f"delivered: {delivered}"]


def draw(world: GridWorld) -> np.ndarray:
    """The grid seen from above (uint8 ``[SIDE, SIDE, 3]``): a one-cell ring around it for
    agents that walk off it, the goal row shaded, the waypoints as red dots, the boxes, and each
    agent as a numbered disc with a pointer where it faces (agents sharing a cell smaller, side
    by side). Anything farther out is not drawn; the panel gives every position."""
    n = world.layout.size
    cell = SIDE / (n + 2)
    image = Image.new("RGB", (SIDE, SIDE), OUTSIDE)
    canvas = ImageDraw.Draw(image)
    font = ImageFont.load_default(size=max(10, int(cell * 0.35)))

    def pixel(x: float, y: float) -> tuple[float, float]:
        return (x + 1.0) * cell, (n + 1.0 - y) * cell

    def rectangle(x: float, y: float, half_w: float, half_h: float, **style: Any) -> None:
        px, py = pixel(x, y)
        canvas.rectangle(
            (px - half_w * cell, py - half_h * cell, px + half_w * cell, py + half_h * cell),
            **style,
        )

    canvas.rectangle((cell, cell, (n + 1) * cell, (n + 1) * cell), fill=FLOOR)
    rectangle(n / 2, world.layout.goal_y, n / 2, 0.5, fill=GOAL)
    for k in range(n + 1):
        canvas.line(((k + 1) * cell, cell, (k + 1) * cell, (n + 1) * cell), fill=LINES, width=2)
        canvas.line((cell, (k + 1) * cell, (n + 1) * cell, (k + 1) * cell), fill=LINES, width=2)
    for x, y in world.layout.waypoints:
        rectangle(x, y, 0.07, 0.07, fill=SPOT)
    for box, label in zip(world.boxes, ("S0", "S1", "BIG"), strict=True):
        rectangle(
            box.x, box.y, 1.0 - 0.1 if box.big else 0.42, 0.42, fill=BOX, outline=BOX_EDGE, width=3
        )
        canvas.text(pixel(box.x, box.y), label, fill=INK, font=font, anchor="mm")

    sharing = Counter((a.x, a.y) for a in world.agents)
    placed: Counter[tuple[float, float]] = Counter()
    discs = []
    for i, agent in enumerate(world.agents):
        here = (agent.x, agent.y)
        shift = (placed[here] - (sharing[here] - 1) / 2) / sharing[here]
        placed[here] += 1
        px, py = pixel(agent.x + shift, agent.y)
        if 0 <= px <= SIDE and 0 <= py <= SIDE:
            discs.append((i, agent.ori, px, py, (0.3 if sharing[here] == 1 else 0.22) * cell))
    for i, _, px, py, radius in discs:
        colour = AGENT_COLOURS[i % len(AGENT_COLOURS)]
        canvas.ellipse(
            (px - radius, py - radius, px + radius, py + radius), fill=colour, outline=INK, width=2
        )
        label = ImageFont.load_default(size=max(9, int(radius * 1.1)))
        canvas.text((px, py), str(i), fill=(255, 255, 255), font=label, anchor="mm")
    for _, ori, px, py, radius in discs:  # over the discs, so a neighbour's never hides one
        dx, dy = DIRECTIONS[ori]
        start = (px + dx * radius, py - dy * radius)
        tip = (px + dx * radius * 1.7, py - dy * radius * 1.7)
        canvas.line((start, tip), fill=INK, width=max(4, int(cell * 0.1)))
    return np.asarray(image)
