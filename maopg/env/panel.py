"""The video panel's named quantities: which a task shows, and how they are drawn.

A task says what its state means through its registered ``panel`` (:mod:`maopg.tasks.panel`:
bars, named values, headings, lines of text); a task registered with ``state_lines`` only
shows those lines, and any other task its ``describe()`` as ``key: value`` lines
(:func:`~maopg.tasks.text.generic_state_lines`), so that a plugin task without a display hook
still gets a readable panel.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from PIL import ImageDraw, ImageFont

from maopg.tasks import task_entry, task_names
from maopg.tasks.panel import Field, Gauge, Heading, PanelItem
from maopg.tasks.text import generic_state_lines

TEXT = (235, 235, 235)
DIM = (150, 150, 160)
BAR = (70, 150, 230)
TROUGH = (52, 52, 60)
MARK = (245, 245, 245)
"""The tick of a gauge's mark: white, since yellow says "chose its option" in the legend."""

ROW = 20
"""Pixels per item."""
BAR_WIDTH = 84
NAME_MAX = 104
"""The widest the names' column gets (a longer name is cut)."""


NOTHING = Heading("no state to show: the task's describe() is empty")
"""The panel of a task that describes nothing (a wrapped PettingZoo game, say)."""


def panel_items(task_name: str, state: Mapping[str, Any]) -> list[PanelItem]:
    """What the panel shows of ``Task.describe()``: the task's registered ``panel``, else its
    ``state_lines``, else :func:`generic_state_lines` (also for a task that is not
    registered); :data:`NOTHING` where that is empty."""
    formatter: Callable[[Mapping[str, Any]], Sequence[PanelItem]] = generic_state_lines
    if task_name in task_names():
        entry = task_entry(task_name)
        formatter = entry.panel_fn() or entry.state_lines_fn() or generic_state_lines
    return list(formatter(state)) or [NOTHING]


def fit(draw: ImageDraw.ImageDraw, text: str, width: float, font: ImageFont.FreeTypeFont) -> str:
    """``text``, cut with an ellipsis to ``width`` pixels in ``font``."""
    if draw.textlength(text, font=font) <= width:
        return text
    while text and draw.textlength(f"{text}…", font=font) > width:
        text = text[:-1]
    return f"{text}…"


def draw_items(
    draw: ImageDraw.ImageDraw,
    items: Sequence[PanelItem],
    box: tuple[int, int, int, int],
    font: ImageFont.FreeTypeFont,
    small: ImageFont.FreeTypeFont,
) -> int:
    """Draw ``items`` top down in ``box`` (left, top, right, bottom), one :data:`ROW` each:
    a heading dim and small; a :class:`Field` as its name in a column, its value beside; a
    :class:`Gauge` as its name, a bar filled to its fraction with its mark as a tick, and its
    text; a string as a line. Everything is cut to the box's width; items past its bottom
    make a last line that says how many were left out. Returns the ``y`` below the last."""
    left, y, right, bottom = box
    named = [item.name for item in items if isinstance(item, Field | Gauge)]
    column = min(NAME_MAX, max((draw.textlength(n, font=small) for n in named), default=0) + 8)
    room = (bottom - y) // ROW
    shown = items if len(items) <= room else items[: max(room - 1, 0)]
    for item in shown:
        if isinstance(item, Heading):
            draw.text(
                (left, y + 3), fit(draw, item.text, right - left, small), fill=DIM, font=small
            )
        elif isinstance(item, Field):
            draw.text((left, y + 2), fit(draw, item.name, column - 6, small), fill=DIM, font=small)
            value = fit(draw, item.value, right - left - column, font)
            draw.text((left + column, y), value, fill=TEXT, font=font)
        elif isinstance(item, Gauge):
            draw.text((left, y + 2), fit(draw, item.name, column - 6, small), fill=DIM, font=small)
            x = left + column
            draw.rectangle((x, y + 5, x + BAR_WIDTH, y + 15), fill=TROUGH)
            filled = min(max(item.fraction, 0.0), 1.0) * BAR_WIDTH
            if filled >= 1:
                draw.rectangle((x, y + 5, x + filled, y + 15), fill=BAR)
            if item.mark is not None:
                at = x + min(max(item.mark, 0.0), 1.0) * BAR_WIDTH
                draw.rectangle((at - 1, y + 2, at + 1, y + 18), fill=MARK)
            text = fit(draw, item.text, right - x - BAR_WIDTH - 8, small)
            draw.text((x + BAR_WIDTH + 8, y + 2), text, fill=TEXT, font=small)
        else:
            draw.text((left, y), fit(draw, str(item), right - left, font), fill=TEXT, font=font)
        y += ROW
    if len(shown) < len(items):
        draw.text((left, y), f"… {len(items) - len(shown)} more", fill=DIM, font=small)
        y += ROW
    return y
