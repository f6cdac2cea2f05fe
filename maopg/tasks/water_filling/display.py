"""How Water Filling's state reads in the video panel: each jar's level as a bar."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from maopg.tasks.panel import Field, Gauge, Heading, PanelItem


def panel(state: Mapping[str, Any]) -> list[PanelItem]:
    """Each jar's true level as a bar, with a tick at the level the robots last saw and how
    many ticks ago they saw it; the fills so far (from ``WaterFilling.describe()``)."""
    items: list[PanelItem] = [Heading("jar levels (| = last seen)")]
    for c, (level, seen, ago) in enumerate(
        zip(state["levels"], state["known_levels"], state["elapsed"], strict=True)
    ):
        items.append(Gauge(f"jar {c}", level, f"{level:.2f}, seen {int(ago)} ago", mark=seen))
    return [*items, Field("fills", str(state["fills"]))]
