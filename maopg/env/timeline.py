"""Who ran which option when: an episode's option timeline, one row of segments per agent.

A :class:`TimelineRecorder` listens to an :class:`~maopg.env.option_env.OptionEnv`'s ticks and
decision points and merges the options each agent ran into :class:`Segment` s: one per option
execution (an agent that chooses the same option again starts a new one), and one per stretch
of ``idle`` (an agent that finished and waits for the others under ``all``). A segment starts
at the tick of the decision point where it was chosen, so ``end - start`` is the number of
ticks it has run. The video draws the timeline as a strip under its views
(:func:`draw_timeline`), ``python -m eval timeline`` as a figure
(:mod:`maopg.experiment.evaluation.timeline`); both colour an option the same
(:func:`option_colours`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from PIL import ImageDraw, ImageFont

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.env.option_env import OptionEnv
from maopg.env.rollout import ReferencePolicy, TickLimit, goes_on_past

IDLE = "idle"
PALETTE = (
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (188, 189, 34),
    (23, 190, 207),
    (174, 199, 232),
    (255, 187, 120),
    (152, 223, 138),
    (255, 152, 150),
    (197, 176, 213),
    (196, 156, 148),
    (247, 182, 210),
    (219, 219, 141),
    (158, 218, 229),
)
"""Matplotlib's ``tab20`` without its greys (kept for ``idle``), in its order."""
IDLE_COLOUR = (127, 127, 127)


@dataclass(frozen=True)
class Segment:
    """One option execution (or one stretch of ``idle``) of one agent."""

    start: int
    """The tick of the decision point where it began (its first tick is ``start + 1``)."""
    end: int
    """The last tick it ran (so far)."""
    option: str
    chosen: bool
    """It began at a decision of its agent (``idle`` is no choice)."""


class TimelineRecorder:
    """Builds the timeline of an episode: :meth:`decide` at every decision point (before
    ``env.step``), :meth:`on_tick` as the environment's tick listener."""

    def __init__(self, agents: int) -> None:
        self._rows: list[list[Segment]] = [[] for _ in range(agents)]
        self._choosing = np.zeros(agents, dtype=bool)

    def decide(self, point: DecisionPoint) -> None:
        """The agents that choose at ``point`` start a new segment with the next tick."""
        self._choosing[:] = point.choosing

    def on_tick(self, env: OptionEnv, reward: float) -> None:
        tick = env.task.ticks
        for i, option in enumerate(env.running_option_names()):
            row = self._rows[i]
            fresh = self._choosing[i] or not row or row[-1].option != option
            if fresh:
                row.append(Segment(tick - 1, tick, option, bool(self._choosing[i])))
            else:
                row[-1] = Segment(row[-1].start, tick, option, row[-1].chosen)
        self._choosing[:] = False

    def rows(self) -> tuple[tuple[Segment, ...], ...]:
        """Each agent's segments so far, in time order."""
        return tuple(tuple(row) for row in self._rows)

    def progress(self, options: Sequence[str], tick: int) -> list[int]:
        """Ticks each agent's option (``options``: what each runs now) has run by the end of
        ``tick``, counting it: during a tick's physics, or once it is recorded. An option
        chosen at the last decision point, or begun since the last recorded tick, is in its
        first."""
        return [
            1 if self._choosing[i] or not row or row[-1].option != option else tick - row[-1].start
            for i, (row, option) in enumerate(zip(self._rows, options, strict=True))
        ]


@dataclass(frozen=True)
class PlayedTimeline:
    """What :func:`play_timeline` recorded."""

    rows: tuple[tuple[Segment, ...], ...]
    ret: float
    ticks: int
    cut: bool
    """The episode went on past the ``max_ticks`` it was played to."""


def play_timeline(
    env: OptionEnv, policy: ReferencePolicy, *, seed: int, max_ticks: int
) -> PlayedTimeline:
    """Play one episode of ``env`` with ``policy`` (no rendering) and return its timeline; an
    episode still running at tick ``max_ticks`` is cut there (``env`` is then left
    mid-episode)."""
    recorder = TimelineRecorder(env.num_agents)
    ret = [0.0]

    def on_tick(tick_env: OptionEnv, reward: float) -> None:
        recorder.on_tick(tick_env, reward)
        ret[0] += reward
        if goes_on_past(tick_env, max_ticks):
            raise TickLimit

    env.add_tick_listener(on_tick)
    try:
        point = env.reset(seed=seed)
        while not point.done:
            recorder.decide(point)
            point = env.step(np.asarray(policy(point)))
    except TickLimit:
        return PlayedTimeline(recorder.rows(), ret[0], env.task.ticks, cut=True)
    finally:
        env.remove_tick_listener(on_tick)
    return PlayedTimeline(recorder.rows(), ret[0], env.task.ticks, cut=False)


def option_colours(spec: EnvSpec) -> dict[str, tuple[int, int, int]]:
    """A colour per option name of the team (the same name, the same colour, whichever agent
    runs it), in the order the agents list them: :data:`PALETTE` in turn, then round again;
    ``idle`` grey."""
    names = dict.fromkeys(name for agent in spec.agents for name in agent.option_names)
    colours = {name: PALETTE[k % len(PALETTE)] for k, name in enumerate(names)}
    return {**colours, IDLE: IDLE_COLOUR}


NAME_WIDTH = 96
"""Pixels of a strip's row kept for the agent's name."""


def draw_timeline(
    draw: ImageDraw.ImageDraw,
    box: tuple[int, int, int, int],
    names: Sequence[str],
    rows: Sequence[Sequence[Segment]],
    ticks: int,
    now: int,
    colours: dict[str, tuple[int, int, int]],
    font: ImageFont.FreeTypeFont,
) -> None:
    """The timeline strip in ``box`` (left, top, right, bottom): a row per agent, its name at
    the left, then a bar per segment from its start to its end over an axis of ``ticks``, in
    its option's colour, with the option's name on it where it fits; a white notch where the
    agent decided; a line at tick ``now``."""
    left, top, right, bottom = box
    x0 = left + NAME_WIDTH
    scale = (right - x0) / max(ticks, 1)
    pitch = (bottom - top) / max(len(names), 1)
    bar = max(4, int(pitch) - 2)
    for i, (name, row) in enumerate(zip(names, rows, strict=True)):
        y = int(top + i * pitch)
        draw.text((left, y + bar / 2), name, fill=(200, 200, 205), font=font, anchor="lm")
        for segment in row:
            a, b = x0 + segment.start * scale, x0 + segment.end * scale
            colour = colours.get(segment.option, IDLE_COLOUR)
            draw.rectangle((a, y, max(a, b - 1), y + bar), fill=colour)
            if b - a > draw.textlength(segment.option, font=font) + 4:
                ink = (0, 0, 0) if sum(colour) > 380 else (255, 255, 255)
                draw.text((a + 2, y + bar / 2), segment.option, fill=ink, font=font, anchor="lm")
            if segment.chosen:
                draw.rectangle((a, y, a + 1, y + bar), fill=(255, 255, 255))
    cursor = x0 + now * scale
    draw.line((cursor, top, cursor, bottom), fill=(255, 214, 64), width=1)
