"""Where a video writes its labels: near their points, never on one another, inside the picture.

A label's place of choice is centred just above its point (or above a point given over the
labelled thing, so that the label does not hide it). Labels are placed one after the
other, in the order given (a task lists its robots first): each takes the free place nearest
its place of choice (no overlap with a label placed before it, nor with any labelled point's
dot, and wholly inside the picture), searched over a grid of offsets around it, then, if that
is full, over the whole picture. A label with no free place left is not drawn rather than
drawn over another. The search is a few array operations per label, so it runs on every frame
of a video.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

import numpy as np

LIFT = 6
"""Pixels between a point and the bottom of its label at the place of choice."""
DOT = 3
"""Half side of the square kept free around every labelled point (its dot)."""
GAP = 1
"""Pixels kept free between two labels."""
STEP = 4
"""Grid of offsets searched around the place of choice (pixels)..."""
REACH = 96
"""...out to this far in each direction, before the whole picture is searched."""


@cache
def _offsets(reach: int, step: int) -> np.ndarray:
    """Offsets ``[M, 2]`` of a square grid, nearest first (ties: upward, then leftward)."""
    span = np.arange(-reach, reach + 1, step)
    dx, dy = (a.ravel() for a in np.meshgrid(span, span))
    order = np.lexsort((dx, dy, np.hypot(dx, dy)))
    return np.stack([dx[order], dy[order]], axis=1)


def place_labels(
    points: np.ndarray,
    sizes: Sequence[tuple[int, int]],
    width: int,
    height: int,
    tops: np.ndarray | None = None,
) -> list[tuple[int, int] | None]:
    """The top-left corner of each label's box, or ``None`` for a label not drawn (its point
    is outside the ``width`` x ``height`` picture or NaN, or no free place is left).

    ``points``: ``[N, 2]`` pixel positions (x right, y down); ``sizes``: each label's
    ``(w, h)``; ``tops``: the pixel each label's place of choice stands on, when not its point
    (one over the labelled thing, so that the label does not hide it; NaN, or one below the
    point: the point).
    Boxes are half-open: a box at ``(x, y)`` of size ``(w, h)`` covers columns
    ``x .. x + w - 1``.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    inside = np.isfinite(points).all(axis=1)
    inside[inside] &= (points[inside] >= 0).all(axis=1)
    inside[inside] &= (points[inside, 0] < width) & (points[inside, 1] < height)
    dots = [
        (px - DOT, py - DOT, px + DOT + 1, py + DOT + 1)
        for px, py in points[inside].round().astype(int).tolist()
    ]
    taken = np.array(dots, dtype=np.int64).reshape(-1, 4)  # x0, y0, x1, y1 (exclusive ends)
    stand = points[:, 1] if tops is None else np.asarray(tops, dtype=np.float64)[:, 1]
    stand = np.where(np.isfinite(stand), np.minimum(stand, points[:, 1]), points[:, 1])
    placed: list[tuple[int, int] | None] = []
    for (px, _), top, (w, h), seen in zip(
        points.tolist(), stand.tolist(), sizes, inside.tolist(), strict=True
    ):
        if not seen or w > width or h > height:
            placed.append(None)
            continue
        choice = np.array([round(px - w / 2), round(top) - LIFT - h])
        spot = _free(choice + _offsets(REACH, STEP), (w, h), taken, width, height)
        if spot is None:  # crowded around the point: anywhere in the picture
            whole = _offsets(max(width, height), max(STEP, min(w, h) // 2))
            spot = _free(choice + whole, (w, h), taken, width, height)
        placed.append(spot)
        if spot is not None:
            x, y = spot
            box = [[x - GAP, y - GAP, x + w + GAP, y + h + GAP]]
            taken = np.concatenate([taken, np.array(box, dtype=np.int64)])
    return placed


def _free(
    corners: np.ndarray, size: tuple[int, int], taken: np.ndarray, width: int, height: int
) -> tuple[int, int] | None:
    """The first of ``corners`` (clamped into the picture) whose box of ``size`` overlaps no
    box of ``taken``, or ``None``."""
    w, h = size
    x = np.clip(corners[:, 0], 0, width - w)
    y = np.clip(corners[:, 1], 0, height - h)
    if len(taken):
        x0, y0, x1, y1 = (taken[:, k][None, :] for k in range(4))
        hits = (x[:, None] < x1) & (x0 < x[:, None] + w) & (y[:, None] < y1) & (y0 < y[:, None] + h)
        free = np.flatnonzero(~hits.any(axis=1))
    else:
        free = np.arange(1)
    if free.size == 0:
        return None
    k = int(free[0])
    return int(x[k]), int(y[k])
