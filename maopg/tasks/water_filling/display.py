"""How Water Filling's state reads in the video panel."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def state_lines(state: Mapping[str, Any]) -> list[str]:
    """Each jar's true level beside what the robots last saw, and when; the fills so far."""
    jars = zip(state["levels"], state["known_levels"], state["elapsed"], strict=True)
    return [
        *(
            f"jar {c}: level {level:.2f} (seen {known:.2f}, {int(ago)} ticks ago)"
            for c, (level, known, ago) in enumerate(jars)
        ),
        f"fills: {state['fills']}",
    ]
