"""How Water Filling's state reads in the video panel."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

LINE_PER_JAR = 6
"""Up to this many jars, one line each; more are tabulated, so the panel stays short."""
TABLE_COLUMNS = 6
"""Jars per group of table lines (what fits the panel's width)."""


def state_lines(state: Mapping[str, Any]) -> list[str]:
    """Each jar's true level beside what the robots last saw, and when; the fills so far.

    Past :data:`LINE_PER_JAR` jars, groups of :data:`TABLE_COLUMNS` jars take four lines (jar
    numbers, levels, levels seen, ticks ago) instead of one line per jar.
    """
    levels, known, ago = state["levels"], state["known_levels"], state["elapsed"]
    fills = f"fills: {state['fills']}"
    if len(levels) <= LINE_PER_JAR:
        jars = zip(levels, known, ago, strict=True)
        return [
            *(
                f"jar {c}: level {level:.2f} (seen {seen:.2f}, {int(t)} ticks ago)"
                for c, (level, seen, t) in enumerate(jars)
            ),
            fills,
        ]
    lines = []
    for first in range(0, len(levels), TABLE_COLUMNS):
        group = slice(first, first + TABLE_COLUMNS)
        lines += [
            _row("jar", [str(c) for c in range(len(levels))[group]]),
            _row("level", [f"{v:.2f}" for v in levels[group]]),
            _row("seen", [f"{v:.2f}" for v in known[group]]),
            _row("ago", [str(int(t)) for t in ago[group]]),
        ]
    return [*lines, fills]


def _row(label: str, cells: Sequence[str]) -> str:
    return f"{label:<6}" + " ".join(f"{cell:>5}" for cell in cells)
