"""Headless rollout videos: the overview camera, every robot's camera, and what is going on.

One frame per **tick** (low-level step), composed as::

    +----------------------------+-----------------+
    |  overview camera (480x640) |  title (3 lines)|
    |  robots and landmarks      |  tick, return,  |
    |  labelled where they stand |  last reward,   |
    |                            |  task state,    |
    |                            |  observations   |
    |                            |  legend         |
    +---------+---------+--------+-----------------+
    | robot 0: option | robot 1: option | ...      |   <- caption: agent and current option
    | camera (upscaled observation)  ...           |
    +----------------------------------------------+

Up to three robots' tiles (256 px) sit in one row under the overview. A bigger team's tiles are
laid out in rows no wider than the overview and the panel (:func:`tile_grid`): 256 px tiles in
up to two rows, then smaller ones (192, 128, 96, 64 px) so that they still fit two rows, and more
rows only past 26 robots; their captions take two lines (agent, option), cut to the tile's width.

A task without a scene films what its :meth:`~maopg.tasks.base.Task.video_frame` draws in the
overview's place (nothing, when it draws nothing) and has a caption row without camera tiles:
every task gets a video.

The robots' tiles show each camera at the observation resolution (``task.config.image_size``)
upscaled with nearest-neighbour, i.e. exactly the pixels an image-based policy sees; a caption
turns yellow on the tick an agent starts a new option, which the legend at the panel's bottom
says. The title (:func:`video_title`) names the task, the strategy, who acts (a trained policy's
method and *training* seed, greedy or sampled; a reference policy's name) and, on a line of its
own, the *episode* seed. The overview labels what the task's
:meth:`~maopg.tasks.base.SceneTask.labels` lists (the robots; Water Filling's jars and Tool
Delivery's humans too) at its projection (:func:`maopg.sim.render.project_points`), in small
text on a dark box that stays inside the picture. The panel's task state comes from the task's
registered ``state_lines`` (:func:`~maopg.tasks.text.generic_state_lines` otherwise); under
it, each agent's observation at the last decision point, by the fields of its named layout.

The option environment only returns at decision points, so per-tick frames come from its tick
listener (:meth:`OptionEnv.add_tick_listener`), registered for the episode and removed after.
A video films at most :data:`VIDEO_MAX_TICKS` ticks, whatever the task's ``max_ticks`` (which a
user may set to a billion): a longer episode is cut there, and its last frame says so.
Everything is deterministic given the seed: physics, policy (if seeded) and rendering.
``python -m eval video`` records one from a checkpoint or a reference policy.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw, ImageFont

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
from maopg.env import DecisionPoint, OptionEnv
from maopg.env.rollout import ReferencePolicy, TickLimit, goes_on_past
from maopg.progress import shows_bar
from maopg.sim.render import CameraRenderer, VideoRenderer, project_points
from maopg.tasks import ObsLayout, SceneTask, Task, task_entry, task_names
from maopg.tasks.text import generic_state_lines

OVERVIEW_SIZE = (480, 640)
"""Height, width of the overview camera frame."""
PANEL_WIDTH = 320
TILE = 256
"""Side of a robot's camera tile: 4x a 64 px observation."""
CAPTION = 28
GAP = 8
BLOCK = 16
"""H.264 encodes 16x16 macroblocks; frames are padded to multiples so the writer never resizes."""
ROW_WIDTH = OVERVIEW_SIZE[1] + PANEL_WIDTH
"""The widest a row of robot tiles gets: the overview and the panel side by side."""
GRID_TILES = (TILE, 192, 128, 96, 64)
"""Tile sides tried in turn for a team whose tiles do not fit one row."""
GRID_ROWS = 2
"""Rows a team's tiles may take before the tiles shrink."""
GRID_CAPTION = 44
"""Height of a two-line caption (agent, then option) over a tile of the grid."""

VIDEO_MAX_TICKS = 1000
"""Ticks filmed at most (about 4 minutes at the default 4 fps; ~2.5 minutes to render on Water
Filling): over three times the longest default episode (Water Filling's 300 ticks)."""

BACKGROUND = (24, 24, 28)
TEXT = (235, 235, 235)
DIM = (150, 150, 160)
HIGHLIGHT = (255, 214, 64)

LABEL_FONT = 13
"""Pixel size of the overview's labels: small, so that 8+ robots and 8+ jars stay apart."""
LABEL_PAD = 2
LABEL_LIFT = 6
"""Pixels between a labelled point and its label's box."""
LABEL_BOX = (12, 12, 16)
"""The labels' background: dark, so the text reads on any floor."""
LEGEND = ((HIGHLIGHT, "caption: chose its option this tick"), (TEXT, "caption: option running"))
"""The caption colours, explained at the bottom of the panel."""
LEGEND_TOP = OVERVIEW_SIZE[0] - 12 - 21 * len(LEGEND)
"""Where the legend starts; the panel's text stops above it."""


# ----------------------------------------------------------------------------- task state text
def state_lines(task_name: str, state: Mapping[str, Any]) -> list[str]:
    """The panel's lines for ``Task.describe()``: the task's registered ``state_lines``, else
    :func:`generic_state_lines` (also for a task that is not registered)."""
    formatter = None
    if task_name in task_names():
        formatter = task_entry(task_name).state_lines_fn()
    return (formatter or generic_state_lines)(state)


def observation_lines(
    name: str, layout: ObsLayout | None, vector: np.ndarray, fits: Callable[[str], bool]
) -> list[str]:
    """An agent's latest observation, field by field (``fits`` says whether a line fits).

    Values read to 2 decimals without trailing zeros (``location 0 1 0 0``, ``elapsed 0 0.67``);
    fields are packed greedily into lines, the first starting with the agent's name.
    """
    fields = layout.split(vector) if layout is not None else {"obs": vector}
    parts = [f"{field} {_format_field(values)}" for field, values in fields.items()]
    lines = [f"{name}:"]
    for part in parts:
        joined = f"{lines[-1]} {part}"
        if fits(joined) or lines[-1].endswith(":"):
            lines[-1] = joined
        else:
            lines.append(f"  {part}")
    return lines


def _format_field(values: np.ndarray) -> str:
    return " ".join(_short(float(v)) for v in values)


def _short(value: float) -> str:
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


# ----------------------------------------------------------------------------- composition
@dataclass(frozen=True)
class Overlay:
    """What is written on one frame."""

    tick: int
    ret: float
    """Episode return so far (sum of the tick rewards up to and including this frame's tick)."""
    reward: float | None
    """Reward of this frame's tick alone (``None`` on the reset frame, before any tick)."""
    options: Sequence[str]
    """Option every agent executes ("-" before the first choice, "idle" while a finished agent
    waits for the others under sync-wait)."""
    started: Sequence[bool]
    """Agents that started their option on this frame's tick (drawn highlighted)."""
    state: Sequence[str]
    """Task state lines."""
    vectors: Sequence[np.ndarray] = ()
    """Each agent's latest observation vector (what its policy last saw), listed by field under
    the state lines; empty: none shown."""
    note: str = ""
    """Highlighted under the tick counter (the last frame of a cut video says so)."""


@dataclass(frozen=True)
class TileGrid:
    """Where the robots' captions and camera tiles go (:func:`tile_grid`)."""

    side: int
    """Width of a robot's cell, and of its camera tile."""
    tile: int
    """Height of a camera tile (0: a task without cameras has captions only)."""
    caption: int
    cols: int
    rows: int
    two_lines: bool
    """Captions as two lines (agent, option) instead of ``agent: option``."""

    @property
    def row_width(self) -> int:
        return self.cols * self.side + (self.cols - 1) * GAP

    @property
    def height(self) -> int:
        """From the top of the first caption to the bottom of the last row."""
        return self.rows * (self.caption + self.tile) + (self.rows - 1) * GAP

    def cell(self, agent: int, width: int) -> tuple[int, int]:
        """Top-left ``(x, y)`` of an agent's caption in a frame ``width`` wide; rows are centred
        as a block, filled left to right, the last one possibly short."""
        row, col = divmod(agent, self.cols)
        x0 = (width - self.row_width) // 2
        y = OVERVIEW_SIZE[0] + GAP + row * (self.caption + self.tile + GAP)
        return x0 + col * (self.side + GAP), y


def tile_grid(agents: int, cameras: bool) -> TileGrid:
    """The layout of ``agents`` robots' tiles (see the module docstring): one row while it fits
    :data:`ROW_WIDTH` (the layout of up to three robots), else the largest of
    :data:`GRID_TILES` whose columns fit the team in :data:`GRID_ROWS` rows (the smallest, in
    as many rows as it takes, past that)."""
    if agents * TILE + (agents - 1) * GAP <= ROW_WIDTH:
        return TileGrid(TILE, TILE if cameras else 0, CAPTION, agents, 1, False)
    for side in GRID_TILES:
        cols = (ROW_WIDTH + GAP) // (side + GAP)
        rows = -(-agents // cols)
        if rows <= GRID_ROWS:
            break
    return TileGrid(side, side if cameras else 0, GRID_CAPTION, cols, rows, True)


class FrameComposer:
    """Renders and composes one video frame of a task (see the module docstring)."""

    def __init__(
        self,
        task: Task,
        agent_names: Sequence[str],
        *,
        layouts: Sequence[ObsLayout | None] | None = None,
        title: str | Sequence[str] = "",
        max_ticks: int | None = None,
        camera_px: int | None = None,
        labels: bool = True,
    ) -> None:
        self.task = task
        self.agent_names = tuple(agent_names)
        self.layouts = tuple(layouts) if layouts is not None else (None,) * len(self.agent_names)
        self.title = (title,) if isinstance(title, str) else tuple(title)
        """The title's lines, each cut to the panel's width (:func:`video_title`)."""
        self.max_ticks = max_ticks
        self.labels = labels and isinstance(task, SceneTask)
        """Whether the overview gets the task's :meth:`~maopg.tasks.base.SceneTask.labels`."""
        self.scene = isinstance(task, SceneTask)
        n = len(self.agent_names)
        oh, ow = OVERVIEW_SIZE
        self.grid = grid = tile_grid(n, self.scene)
        self.width = _round_up(max(ROW_WIDTH, grid.row_width), BLOCK)
        self.height = _round_up(oh + GAP + grid.height, BLOCK)
        if isinstance(task, SceneTask):
            px = camera_px or task.config.image_size
            self._overview = VideoRenderer(task.scene.model, oh, ow, camera="overview")
            self._cameras = CameraRenderer(task.scene.model, px, px)
            self._camera_ids = [robot.camera_id for robot in task.agent_robots]
            self._camera_buf = np.empty((n, px, px, 3), np.uint8)
            self._data = task.scene.data
        self._font = ImageFont.load_default(size=18)
        self._small = ImageFont.load_default(size=15)
        self._label_font = ImageFont.load_default(size=LABEL_FONT)

    @classmethod
    def of_env(
        cls, env: OptionEnv, title: str | Sequence[str], camera_px: int | None = None
    ) -> FrameComposer:
        """The composer of ``env``'s frames: its task, agents, observation layouts and tick
        limit (a rollout video and the PettingZoo view's ``render()`` draw the same frame)."""
        return cls(
            env.task,
            env.spec.agent_names,
            layouts=[agent.layout for agent in env.spec.agents],
            title=title,
            max_ticks=env.spec.max_ticks,
            camera_px=camera_px,
        )

    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.height, self.width, 3)

    def _picture(self) -> Image.Image | None:
        """The overview: the scene's camera, or what a scene-less task draws (fit to size)."""
        if self.scene:
            return Image.fromarray(self._overview.frame(self._data))
        frame = self.task.video_frame()
        if frame is None:
            return None
        picture = Image.fromarray(np.asarray(frame, dtype=np.uint8))
        scale = min(OVERVIEW_SIZE[1] / picture.width, OVERVIEW_SIZE[0] / picture.height)
        size = (max(1, int(picture.width * scale)), max(1, int(picture.height * scale)))
        return picture.resize(size, Image.NEAREST)

    def compose(self, overlay: Overlay) -> np.ndarray:
        """Render the current state and draw ``overlay``: uint8 ``[H, W, 3]``."""
        canvas = Image.new("RGB", (self.width, self.height), BACKGROUND)
        picture = self._picture()
        if picture is not None:
            canvas.paste(picture, (0, 0))
        draw = ImageDraw.Draw(canvas)
        if self.labels:
            self._draw_labels(draw)
        self._draw_panel(draw, overlay)
        self._draw_legend(draw)
        if self.scene:
            self._cameras.render(self._data, self._camera_ids, out=self._camera_buf)

        grid = self.grid
        for i, name in enumerate(self.agent_names):
            x, y = grid.cell(i, self.width)
            colour = HIGHLIGHT if overlay.started[i] else TEXT
            if grid.two_lines:
                for k, text in enumerate((name, str(overlay.options[i]))):
                    text = self._fit(draw, text, grid.side - 4, self._small)
                    draw.text((x + 2, y + 2 + 20 * k), text, fill=colour, font=self._small)
            else:
                caption = f"{name}: {overlay.options[i]}"
                draw.text((x + 2, y + 4), caption, fill=colour, font=self._small)
            if self.scene:
                side = grid.side
                tile = Image.fromarray(self._camera_buf[i]).resize((side, side), Image.NEAREST)
                canvas.paste(tile, (x, y + grid.caption))
        return np.asarray(canvas)

    @staticmethod
    def _fit(draw: ImageDraw.ImageDraw, text: str, width: int, font: ImageFont.ImageFont) -> str:
        """``text``, cut with an ellipsis to ``width`` pixels in ``font``."""
        if draw.textlength(text, font=font) <= width:
            return text
        while text and draw.textlength(f"{text}…", font=font) > width:
            text = text[:-1]
        return f"{text}…"

    def _draw_labels(self, draw: ImageDraw.ImageDraw) -> None:
        """The task's labels at their projections on the overview: a dot on the point and the
        text in a dark box just above it (below it where that box would cover an earlier
        label), kept inside the overview; a point outside the picture is not labelled."""
        labels = self.task.labels()  # type: ignore[attr-defined]  (self.labels: a scene task)
        if not labels:
            return
        oh, ow = OVERVIEW_SIZE
        model, data = self.task.scene.model, self._data  # type: ignore[attr-defined]
        points = np.array([xyz for _, xyz in labels], dtype=np.float64)
        pixels = project_points(model, data, self._overview.camera, points, oh, ow)
        taken: list[tuple[int, int, int, int]] = []
        for (text, _), (px, py) in zip(labels, pixels, strict=True):
            if not (0 <= px < ow and 0 <= py < oh):  # NaN (behind the camera) fails too
                continue
            left, top, right, bottom = draw.textbbox((0, 0), text, font=self._label_font)
            w, h = right - left + 2 * LABEL_PAD, bottom - top + 2 * LABEL_PAD
            x = int(min(max(px - w / 2, 0), ow - w))
            above, below = int(py) - LABEL_LIFT - h, int(py) + LABEL_LIFT
            y = above if above >= 0 else below
            if any(_overlaps((x, y, x + w, y + h), box) for box in taken) and below + h <= oh:
                y = below
            y = min(max(y, 0), oh - h)
            box = (x, y, x + w - 1, y + h - 1)  # PIL includes both corners
            taken.append(box)
            draw.rectangle(box, fill=LABEL_BOX)
            draw.text(
                (x + LABEL_PAD - left, y + LABEL_PAD - top), text, fill=TEXT, font=self._label_font
            )
            dx, dy = min(max(px, 2), ow - 3), min(max(py, 2), oh - 3)  # the dot stays inside
            draw.ellipse((dx - 2, dy - 2, dx + 2, dy + 2), fill=TEXT, outline=LABEL_BOX)

    def _draw_legend(self, draw: ImageDraw.ImageDraw) -> None:
        """What the caption colours mean, at the bottom of the panel (:data:`LEGEND`)."""
        x, y = OVERVIEW_SIZE[1] + 12, LEGEND_TOP
        for colour, text in LEGEND:
            draw.rectangle((x, y + 4, x + 10, y + 14), fill=colour)
            draw.text((x + 16, y), text, fill=colour, font=self._small)
            y += 21

    def _draw_panel(self, draw: ImageDraw.ImageDraw, overlay: Overlay) -> None:
        x, y = OVERVIEW_SIZE[1] + 12, 12
        width = PANEL_WIDTH - 24
        for line in self.title:
            draw.text((x, y), self._fit(draw, line, width, self._small), fill=DIM, font=self._small)
            y += 21
        y += 4
        limit = f" / {self.max_ticks}" if self.max_ticks else ""
        head = [(f"tick {overlay.tick}{limit}", TEXT)]
        head.append((f"return {overlay.ret:+.1f}", TEXT))
        last = "-" if overlay.reward is None else f"{overlay.reward:+.1f}"
        head.append((f"reward {last} (last tick)", TEXT))
        if overlay.note:
            head.append((overlay.note, HIGHLIGHT))
        for text, colour in head:
            draw.text((x, y), text, fill=colour, font=self._font)
            y += 26
        y += 8
        for line in overlay.state:
            if y > LEGEND_TOP - 21:
                return  # the panel is full (a task with very many state lines)
            draw.text((x, y), line, fill=TEXT, font=self._small)
            y += 21
        y += 8

        def fits(text: str) -> bool:
            return draw.textlength(text, font=self._small) <= width

        for name, layout, vector in zip(
            self.agent_names, self.layouts, overlay.vectors, strict=False
        ):
            for line in observation_lines(name, layout, vector, fits):
                if y > LEGEND_TOP - 21:
                    return  # the panel is full
                draw.text((x, y), line, fill=DIM, font=self._small)
                y += 21

    def close(self) -> None:
        if self.scene:
            self._overview.close()
            self._cameras.close()


def _overlaps(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _round_up(value: int, block: int) -> int:
    return -(-value // block) * block


# ----------------------------------------------------------------------------- recording
def video_title(task: str, strategy: str, policy_label: str, seed: int) -> list[str]:
    """The title's lines: what runs, who acts (the policy and its *training* seed, when it has
    one) and the *episode* seed, each on its own line so neither seed is read for the other."""
    lines = [f"{task} | {strategy}"]
    if policy_label:
        lines.append(policy_label)
    return [*lines, f"episode seed {seed}"]


@dataclass
class RecordedEpisode:
    """What :func:`record_episode` wrote."""

    path: Path
    frames: int
    shape: tuple[int, int, int]
    ret: float
    ticks: int
    solved: bool
    """``False`` for a cut episode: it did not finish."""
    cut: bool = False
    """The episode went on past ``max_ticks`` of :func:`record_episode`; the video stops there."""


def record_episode(
    env: OptionEnv,
    policy: ReferencePolicy,
    path: str | Path,
    *,
    seed: int = 0,
    fps: int = 4,
    camera_px: int | None = None,
    max_ticks: int | None = None,
    policy_label: str = "",
    progress: bool = False,
) -> RecordedEpisode:
    """Play one episode of ``env``'s task with ``policy`` and write it to ``path`` (MP4).

    One frame at reset and one after every tick, so ``frames == ticks + 1``. ``policy`` maps a
    :class:`DecisionPoint` to a joint option (a reference policy or :class:`eval` 's adapter
    of a trained network). A scene task is filmed by its ``overview`` camera; any other task
    by its ``video_frame`` hook, or as its state panel alone.

    An episode still running at tick ``max_ticks`` (default :data:`VIDEO_MAX_TICKS`) is cut
    there, in the middle of an option if need be, so a video's length is bounded whatever the
    task's settings; the last frame says so. ``env`` is then left mid-episode (reset it before
    stepping it again).

    The title names the task, the strategy, ``policy_label`` (who acts: ``async seed 2
    (sampled)``, ``scripted``; :meth:`maopg.experiment.evaluation.loading.Trained.label`) and the
    episode's ``seed`` (:func:`video_title`). ``progress`` shows a bar over the ticks on stderr; its
    total is the bounded length, and it stops early when the episode ends first.
    """
    import imageio.v2 as imageio
    from tqdm import tqdm

    task = env.task
    n = env.num_agents
    title = video_title(task.name, env.strategy.value, policy_label, seed)
    composer = FrameComposer.of_env(env, title, camera_px)
    path = Path(path)
    if path.suffix.lower() != ".mp4":  # before anything is written: ffmpeg would leave a stub
        raise ValueError(f"video path {path}: must end in .mp4 (an H.264 MP4 is written)")
    path.parent.mkdir(parents=True, exist_ok=True)
    options = ["-"] * n
    started = np.zeros(n, dtype=bool)
    total = [0.0]
    seen: list[Sequence[np.ndarray]] = [()]  # the observations at the last decision point
    writer = imageio.get_writer(path, fps=fps, codec="libx264", macro_block_size=BLOCK)
    frames = [0]
    limit = VIDEO_MAX_TICKS if max_ticks is None else max_ticks
    bar = tqdm(
        total=min(limit, env.spec.max_ticks),
        desc=f"video {path.name}",
        unit="tick",
        disable=not shows_bar(progress),
        leave=False,
    )

    def write(tick: int, reward: float | None, note: str = "") -> None:
        overlay = Overlay(
            tick=tick,
            ret=total[0],
            reward=reward,
            options=list(options),
            started=started.tolist(),
            state=state_lines(task.name, task.describe()),
            vectors=seen[0],
            note=note,
        )
        writer.append_data(composer.compose(overlay))
        frames[0] += 1

    def on_tick(tick_env: OptionEnv, reward: float) -> None:
        # what executes now: a finished agent waiting for the others under sync-wait is "idle"
        options[:] = tick_env.running_option_names()
        total[0] += reward
        cut = goes_on_past(tick_env, limit)
        write(task.ticks, reward, "video cut (episode goes on)" if cut else "")
        bar.update()
        started[:] = False
        if cut:
            raise TickLimit

    env.add_tick_listener(on_tick)
    try:
        point: DecisionPoint = env.reset(seed=seed)
        seen[0] = point.vectors
        write(0, None)
        while not point.done:
            seen[0] = point.vectors
            joint = np.asarray(policy(point))
            started[:] = point.choosing
            point = env.step(joint)
    except TickLimit:
        return RecordedEpisode(path, frames[0], composer.shape, total[0], limit, False, cut=True)
    finally:
        env.remove_tick_listener(on_tick)
        bar.close()
        writer.close()
        composer.close()
    episode = point.info["episode"]
    return RecordedEpisode(
        path, frames[0], composer.shape, episode["return"], episode["ticks"], episode["solved"]
    )
