"""Progress on stderr: tqdm bars on a terminal, a few plain lines in a log.

A tqdm bar redraws itself in place with carriage returns. Written to a file or a pipe (a job's
log, ``python -m train ... 2> train.log``), every redraw stays: a 30K-sample Tool Delivery run
left 943 of them. So where stderr is no terminal, the training's bar (:func:`run_progress`)
prints one line per tenth of the run instead, and the short bars of what follows training
(evaluation, video, its GIF: :func:`shows_bar`) print nothing — the ``note: after training``
line that announces them says what comes.
"""

from __future__ import annotations

import sys
import time
from typing import Any, Protocol

from tqdm import tqdm

LOG_LINES = 10
"""Lines a run's progress prints in a log (one per tenth of its budget)."""


def on_terminal() -> bool:
    """Whether stderr, where progress goes, is a terminal."""
    return sys.stderr.isatty()


def shows_bar(progress: bool) -> bool:
    """Whether a short bar is drawn: ``progress`` asked for it and stderr is a terminal."""
    return progress and on_terminal()


class Progress(Protocol):
    """What the trainer and its step watch use of a bar: tqdm's own names."""

    n: float
    total: float

    def update(self, n: float = 1) -> Any: ...

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None: ...

    def refresh(self) -> Any: ...

    def write(self, s: str, file: Any = None) -> None:
        """A line of its own, around the bar (tqdm clears and redraws it)."""

    def close(self) -> None: ...


class LogLines:
    """A run's progress as :data:`LOG_LINES` plain lines on stderr, one each time the count
    passes another tenth of ``total`` (checked at :meth:`refresh`, once an iteration), and the
    last at :meth:`close`: ``desc: n/total unit (p%), elapsed, postfix``."""

    def __init__(self, *, total: int, initial: int, desc: str, unit: str) -> None:
        self.total, self.n, self.desc, self.unit = total, initial, desc, unit
        self.postfix = ""
        self._start = time.perf_counter()
        self._said = initial
        self._next = self._mark_after(initial)

    def _mark_after(self, n: float) -> float:
        step = self.total / LOG_LINES
        return (int(n // step) + 1) * step

    def update(self, n: float = 1) -> None:
        self.n += n

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        self.postfix = s
        if refresh:
            self.refresh()

    def refresh(self) -> None:
        if self.n >= self._next:
            self._say()

    def write(self, s: str, file: Any = None) -> None:
        print(s, file=file or sys.stderr, flush=True)

    def close(self) -> None:
        if self.n != self._said:
            self._say()

    def _say(self) -> None:
        elapsed = time.perf_counter() - self._start
        share = self.n / self.total if self.total else 1.0
        extra = f", {self.postfix}" if self.postfix else ""
        print(
            f"{self.desc}: {self.n:.0f}/{self.total} {self.unit}s ({share:.0%}), "
            f"{elapsed:.0f}s{extra}",
            file=sys.stderr,
            flush=True,
        )
        self._said = self.n
        self._next = self._mark_after(self.n)


def run_progress(*, total: int, initial: int, desc: str, unit: str, enabled: bool) -> Progress:
    """A run's progress: a tqdm bar on a terminal, :class:`LogLines` elsewhere (a disabled
    bar without ``enabled``)."""
    if enabled and not on_terminal():
        return LogLines(total=total, initial=initial, desc=desc, unit=unit)
    return tqdm(
        total=total,
        initial=initial,
        unit=unit,
        desc=desc,
        disable=not enabled,
        dynamic_ncols=True,
    )
