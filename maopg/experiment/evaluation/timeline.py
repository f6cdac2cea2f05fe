"""An episode's option timeline as a figure (``python -m eval timeline``).

One row per agent, one bar per option execution from the decision point that chose it to its
last tick, coloured by option as the video's strip colours it
(:func:`maopg.env.timeline.option_colours`), its name on it where it fits; a black notch marks
each decision of the agent, and the team's decision points (any agent chose) are faint vertical
lines. The episode is played once without rendering (:func:`maopg.env.timeline.play_timeline`),
bounded at :data:`maopg.env.video.VIDEO_MAX_TICKS` ticks as a video is.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from maopg.env import OptionEnv
from maopg.env.rollout import ReferencePolicy
from maopg.env.timeline import IDLE, PlayedTimeline, Segment, option_colours, play_timeline
from maopg.env.video import VIDEO_MAX_TICKS

CHAR_INCHES = 0.06
"""Width of a character of the bars' 7-point names (the axes take about 3/4 of the figure)."""
FORMATS = (".png", ".svg", ".pdf")
"""What ``--out`` may end in (matplotlib writes the format its suffix names)."""


def check_out(path: Path) -> None:
    """Refuse, before anything runs, an ``--out`` matplotlib would not write."""
    if path.suffix.lower() not in FORMATS:
        raise ValueError(f"--out {path}: must end in {', '.join(FORMATS)} (the figure's format)")


def draw_figure(
    played: PlayedTimeline,
    agents: Sequence[str],
    colours: dict[str, tuple[int, int, int]],
    title: str,
    path: Path,
) -> Path:
    """Write the timeline of ``played`` to ``path`` (see the module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    ticks = max(played.ticks, 1)
    width = max(8.0, min(16.0, ticks / 15))
    fig, ax = plt.subplots(figsize=(width, 1.2 + 0.55 * len(agents)))
    per_char = CHAR_INCHES * ticks / (0.75 * width)  # ticks a character of a bar's name takes
    decisions = sorted({s.start for row in played.rows for s in row if s.chosen})
    for tick in decisions:
        ax.axvline(tick, color="0.85", linewidth=0.6, zorder=0)
    used: dict[str, tuple[float, float, float]] = {}
    for i, row in enumerate(played.rows):
        y = len(agents) - 1 - i  # the first agent on top
        for segment in row:
            colour = tuple(c / 255 for c in colours.get(segment.option, colours[IDLE]))
            used.setdefault(segment.option, colour)  # type: ignore[arg-type]
            _bar(ax, segment, y, colour, per_char)
    ax.set_yticks(range(len(agents)), list(reversed(agents)))
    ax.set_ylim(-0.6, len(agents) - 0.4)
    ax.set_xlim(0, ticks)
    ax.set_xlabel("tick")
    ax.set_title(title, fontsize=10)
    handles = [Patch(color=c, label=name) for name, c in used.items()]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _bar(ax, segment: Segment, y: int, colour: tuple[float, float, float], per_char: float) -> None:
    """One segment's bar, its notch if chosen, and its name where it fits."""
    width = segment.end - segment.start
    ax.barh(y, width, left=segment.start, height=0.7, color=colour, edgecolor="white", lw=0.5)
    if segment.chosen:
        ax.plot([segment.start] * 2, [y - 0.35, y + 0.35], color="black", linewidth=1.2)
    if width >= (len(segment.option) + 1) * per_char:
        ink = "black" if sum(colour) > 1.5 else "white"
        ax.text(segment.start + 0.3, y, segment.option, va="center", fontsize=7, color=ink)


def write_timeline(
    env: OptionEnv, policy: ReferencePolicy, out: Path, *, seed: int, policy_label: str
) -> tuple[Path, PlayedTimeline]:
    """Play one episode of ``env`` with ``policy`` at ``seed`` and draw its timeline to
    ``out``; returns the path and what was played."""
    check_out(out)
    played = play_timeline(env, policy, seed=seed, max_ticks=VIDEO_MAX_TICKS)
    cut = f", cut at tick {played.ticks}" if played.cut else ""
    title = (
        f"{env.spec.task} | {env.strategy.value} | {policy_label} | episode seed {seed}: "
        f"return {played.ret:.1f} in {played.ticks} ticks{cut}"
    )
    colours = option_colours(env.spec)
    return draw_figure(played, env.spec.agent_names, colours, title, out), played
