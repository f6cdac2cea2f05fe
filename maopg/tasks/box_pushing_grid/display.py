"""How Box Pushing looks in a video: the panel's named quantities and a top-down drawing of
the grid."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from maopg.tasks.box_pushing_grid.world import BOX_NAMES, DIRECTIONS, GridWorld
from maopg.tasks.panel import Field, Gauge, Heading, PanelItem

SIDE = 480
"""Pixels a side of the drawing (the video's overview is 480 px high)."""
FLOOR, OUTSIDE, LINES = (232, 232, 224), (60, 60, 66), (170, 170, 170)
GOAL = (250, 226, 120)
SPOT = (178, 34, 34)
BOX, BOX_EDGE = (196, 140, 60), (110, 72, 20)
AGENT_COLOURS = ((40, 160, 70), (50, 90, 200), (140, 60, 190))
INK = (20, 20, 20)


FACING = {"N": "north", "E": "east", "S": "south", "W": "west"}


def box_pushing_items(state: Mapping[str, Any], goal: float) -> list[PanelItem]:
    """Both Box Pushing tasks' panel (from their ``describe()``, positions in cells): each
    box's way up to the goal as a bar (its centre's row over ``goal``, the row where it counts
    as delivered) with the rows it has still to go, then where each robot stands and faces,
    and the waypoint it last reached where the task says (what a joint push checks)."""
    items: list[PanelItem] = [Heading("boxes: way to the goal row")]
    for name, (_, y) in zip(BOX_NAMES, state["boxes"], strict=True):
        if name in state["delivered"]:
            items.append(Gauge(name, 1.0, "delivered"))
        else:
            items.append(Gauge(name, y / goal, f"{max(0.0, goal - y):.1f} rows to go"))
    items.append(Heading("robots: cell, facing"))
    reached = state.get("reached", [None] * len(state["positions"]))
    for i, ((x, y), facing, spot) in enumerate(
        zip(state["positions"], state["facing"], reached, strict=True)
    ):
        at = f", at {spot}" if spot not in (None, "-") else ""
        items.append(Field(f"agent{i}", f"({x:.1f}, {y:.1f}) {FACING[facing]}{at}"))
    return items


def panel(state: Mapping[str, Any]) -> list[PanelItem]:
    """The grid's panel (:func:`box_pushing_items`; a box is delivered in the top row)."""
    return box_pushing_items(state, goal=state["size"] - 0.5)


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
