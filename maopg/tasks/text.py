"""Task state as short lines of text, for the video panel and logs.

A task may register its own formatter of :meth:`~maopg.tasks.base.Task.describe` (its
``state_lines``); :func:`generic_state_lines` serves every task that does not.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np


def format_value(value: Any) -> str:
    """A describe() value in a few characters: floats to 2 decimals, sequences bracketed."""
    if isinstance(value, float):
        return f"{value:.2f}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    if isinstance(value, np.ndarray):
        return format_value(value.tolist())
    return str(value)


def generic_state_lines(state: Mapping[str, Any]) -> list[str]:
    """``key: value`` per entry of ``Task.describe()`` (floats to 2 decimals)."""
    return [f"{key.replace('_', ' ')}: {format_value(value)}" for key, value in state.items()]
