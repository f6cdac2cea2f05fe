"""Headless rollout videos: the overview, every robot's camera, the task's state, the options.

:data:`FRAMES_PER_TICK` frames per **tick** (low-level step), played at :data:`FPS` frames a
second (a tick a quarter of a second), composed as::

    +----------------------------+-----------------+
    |  overview (480x640), framed|  title          |
    |  to the scene; robots and  |  tick, return   |
    |  landmarks labelled        |  the task's     |
    |                            |  named state    |
    |                            |  legend         |
    +---------+---------+--------+-----------------+
    | robot 0: option, k ticks | robot 1: ...      |   <- caption: agent, option, its ticks
    | camera (upscaled observation)  ...           |
    +----------------------------------------------+
    | robot 0  [GoToWS ][GetTool   ]|              |   <- option timeline, one row per robot
    | robot 1  [Wait      ][PassTo ]|              |
    +----------------------------------------------+

**Motion.** The frames between two ticks are the physics states the tick passes through, not
pictures blended from the tick's ends: the scene calls the recorder back at evenly spaced
physics steps inside the tick (:meth:`maopg.sim.scene.Scene.watch_substeps`), which leaves the
trajectory bit for bit as it is. A task without a scene (a grid, a PettingZoo game) changes
only at ticks, so each of its ticks is shown for :data:`FRAMES_PER_TICK` frames. Only the
overview is rendered on every frame: the panel, the captions and the timeline change once a
tick and are drawn then, and the robots' cameras are rendered at the end of each tick (a
policy sees them at its decision points only).

**Cost.** The overview renders as the observations do (no shadows, reflections nor
multisampling, only the geoms in view: :class:`~maopg.sim.render.VideoRenderer`), the labels
are pasted from text drawn once, and the encoder runs at :data:`ENCODER`'s speed setting;
``bench/perf/video_speed.py`` measures the old path (one frame a tick, MuJoCo's default
settings) beside this one.

**Overview.** The camera keeps the direction of the arena's ``overview`` camera and is moved
as close as the scene's extent allows (:func:`maopg.sim.framing.overview_view`), at the first
frame. The overview labels what the task's :meth:`~maopg.tasks.base.SceneTask.labels` lists
(the robots; Water Filling's jars and Tool Delivery's humans too) at its projection, in small
text on dark boxes that :func:`maopg.env.labels.place_labels` keeps apart and inside the
picture. A task without a scene films what its :meth:`~maopg.tasks.base.Task.video_frame`
draws in the overview's place (nothing, when it draws nothing) and has a caption row without
camera tiles: every task gets a video.

**Robots.** Up to three robots' tiles (256 px) sit in one row under the overview. A bigger
team's tiles are laid out in rows no wider than the overview and the panel (:func:`tile_grid`):
256 px tiles in up to two rows, then smaller ones (192, 128, 96, 64 px) so that they still fit
two rows, and more rows only past 26 robots; their captions take two lines (agent, option), cut
to the tile's width. The tiles show each camera at the observation resolution
(``task.config.image_size``) upscaled with nearest-neighbour, i.e. the pixels an image-based
policy sees. Where the task's cameras give depth or segmentation too (``env.camera_channels``),
each robot's cell holds a tile per channel side by side (colour, depth in grey, classes in a
fixed palette: :mod:`maopg.env.camera_tiles`), and the tiles shrink to fit as a bigger team's
do; a caption names the option its robot runs and for how many ticks it has, and
turns yellow during the tick an agent starts a new option, which the legend says.

**Panel and timeline.** The title (:func:`video_title`) names the task, the strategy, who acts
(a trained policy's method and *training* seed, greedy or sampled; a reference policy's name)
and, on a line of its own, the *episode* seed. Under the tick and the return, the task's state
as named quantities: bars, named values (:func:`maopg.env.panel.panel_items`: the task's
``panel``, else its text lines). The strip at the bottom is the option timeline so far
(:mod:`maopg.env.timeline`): a bar per option, coloured by option, a notch at each decision,
a line at the current tick.

The option environment only returns at decision points, so per-tick frames come from its tick
listener (:meth:`OptionEnv.add_tick_listener`), registered for the episode and removed after.
A video films at most :data:`VIDEO_MAX_TICKS` ticks, whatever the task's ``max_ticks`` (which a
user may set to a billion): a longer episode is cut there, and its last frame says so.
Everything is deterministic given the seed: physics, policy (if seeded) and rendering.
``python -m eval video`` records one from a checkpoint or a reference policy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
from maopg.env import DecisionPoint, OptionEnv
from maopg.env.camera_tiles import channel_tiles
from maopg.env.labels import place_labels
from maopg.env.panel import draw_items, fit, panel_items
from maopg.env.rollout import ReferencePolicy, TickLimit, goes_on_past
from maopg.env.timeline import Segment, TimelineRecorder, draw_timeline, option_colours
from maopg.progress import shows_bar
from maopg.sim.channels import RGB
from maopg.sim.framing import overview_view
from maopg.sim.render import VideoRenderer, View
from maopg.tasks import SceneTask, Task
from maopg.tasks.panel import PanelItem

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
VIEW_GAP = 4
"""Pixels between the tiles of one robot's channels."""
GRID_CAPTION = 44
"""Height of a two-line caption (agent, then option) over a tile of the grid."""
TIMELINE_PITCH = (18, 12)
"""Pixels per robot in the timeline strip: up to four robots, then more."""

FRAMES_PER_TICK = 4
"""Frames a tick is shown for: physics states at a quarter, half, three quarters and the end."""
FPS = 16
"""Frames a second: four ticks a second, the pace of the one-frame-a-tick videos at 4 fps."""
ENCODER = ("-preset", "veryfast")
"""x264's speed setting (``bench/perf/video_speed.py`` prints the encoder's CPU time)."""

VIDEO_MAX_TICKS = 1000
"""Ticks filmed at most (about 4 minutes of video at four ticks a second): over three times the
longest default episode (Water Filling's 300 ticks)."""

BACKGROUND = (24, 24, 28)
TEXT = (235, 235, 235)
DIM = (150, 150, 160)
HIGHLIGHT = (255, 214, 64)

LABEL_FONT = 13
"""Pixel size of the overview's labels: small, so that 8+ robots and 8+ jars stay apart."""
LABEL_PAD = 2
LABEL_OVER = 0.3
"""Metres over a labelled point that its label stands on: clear of a robot's body."""
LABEL_BOX = (12, 12, 16)
"""The labels' background: dark, so the text reads on any floor."""
LEGEND = ((HIGHLIGHT, "caption: chose its option this tick"), (TEXT, "caption: option running"))
"""The caption colours, explained at the bottom of the panel."""
LEGEND_TOP = OVERVIEW_SIZE[0] - 12 - 21 * len(LEGEND)
"""Where the legend starts; the panel's items stop above it."""


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
    state: Sequence[PanelItem]
    """The task's state as the panel's items (:func:`maopg.env.panel.panel_items`)."""
    note: str = ""
    """Highlighted under the tick counter (the last frame of a cut video says so)."""
    progress: Sequence[int] = ()
    """Ticks each agent's option has run, this frame's tick included (empty: not shown)."""
    timeline: Sequence[Sequence[Segment]] = ()
    """Each agent's options so far (:class:`~maopg.env.timeline.TimelineRecorder`)."""


@dataclass(frozen=True)
class TileGrid:
    """Where the robots' captions and camera tiles go (:func:`tile_grid`)."""

    side: int
    """Width of a robot's cell: its camera tiles side by side."""
    tile: int
    """Side of a camera tile (0: a task without cameras has captions only)."""
    caption: int
    cols: int
    rows: int
    two_lines: bool
    """Captions as two lines (agent, option) instead of ``agent: option``."""
    views: int = 1
    """Tiles per robot: one per camera channel."""

    def tile_left(self, view: int) -> int:
        """Where tile ``view`` of a cell starts, from the cell's left edge."""
        return view * (self.tile + VIEW_GAP)

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


def tile_grid(agents: int, cameras: bool, views: int = 1) -> TileGrid:
    """The layout of ``agents`` robots' cells of ``views`` tiles each (see the module
    docstring): one row of :data:`TILE` tiles while it fits :data:`ROW_WIDTH` (the layout of
    up to three robots with one tile each), else the largest of :data:`GRID_TILES` whose
    columns fit the team in :data:`GRID_ROWS` rows (the smallest, in as many rows as it takes,
    past that)."""
    views = views if cameras else 1

    def cell(tile: int) -> int:
        return views * tile + (views - 1) * VIEW_GAP

    if agents * cell(TILE) + (agents - 1) * GAP <= ROW_WIDTH:
        return TileGrid(cell(TILE), TILE if cameras else 0, CAPTION, agents, 1, False, views)
    for tile in GRID_TILES:
        cols = max(1, (ROW_WIDTH + GAP) // (cell(tile) + GAP))
        rows = -(-agents // cols)
        if rows <= GRID_ROWS:
            break
    return TileGrid(cell(tile), tile if cameras else 0, GRID_CAPTION, cols, rows, True, views)


def timeline_height(agents: int) -> int:
    """Height of the timeline strip of ``agents`` robots (:data:`TIMELINE_PITCH`)."""
    return agents * TIMELINE_PITCH[agents > 4] + 4


@cache
def _font(size: int) -> ImageFont.FreeTypeFont:
    return ImageFont.load_default(size=size)


class FrameComposer:
    """Renders and composes the video frames of a task (see the module docstring).

    The frame is kept between calls: :meth:`compose` redraws the panel, the captions and the
    timeline only when what they show changed, and renders the views every time.
    """

    def __init__(
        self,
        task: Task,
        agent_names: Sequence[str],
        *,
        title: str | Sequence[str] = "",
        max_ticks: int | None = None,
        camera_px: int | None = None,
        labels: bool = True,
        colours: dict[str, tuple[int, int, int]] | None = None,
        timeline_ticks: int | None = None,
    ) -> None:
        self.task = task
        self.agent_names = tuple(agent_names)
        self.title = (title,) if isinstance(title, str) else tuple(title)
        """The title's lines, each cut to the panel's width (:func:`video_title`)."""
        self.max_ticks = max_ticks
        self.labels = labels and isinstance(task, SceneTask)
        """Whether the overview gets the task's :meth:`~maopg.tasks.base.SceneTask.labels`."""
        self.scene = isinstance(task, SceneTask)
        self.colours = colours or {}
        """Each option's colour in the timeline (:func:`~maopg.env.timeline.option_colours`)."""
        self.timeline_ticks = timeline_ticks or max_ticks or 1
        """The ticks the timeline's axis spans."""
        n = len(self.agent_names)
        oh, ow = OVERVIEW_SIZE
        self.channels = task.image_channels() if isinstance(task, SceneTask) else RGB
        """What the robots' tiles show, a tile per channel (the task's camera channels)."""
        self.grid = grid = tile_grid(n, self.scene, len(self.channels.names))
        self.width = _round_up(max(ROW_WIDTH, grid.row_width), BLOCK)
        self.timeline_top = oh + GAP + grid.height + GAP
        self.height = _round_up(self.timeline_top + timeline_height(n), BLOCK)
        self._canvas = np.empty((self.height, self.width, 3), np.uint8)
        self._canvas[:] = BACKGROUND
        self._drawn: dict[str, object] = {}
        """What each part of the frame shows now (panel, captions, timeline)."""
        self.view: View | None = None
        """The overview's view, fitted to the scene at the first frame."""
        if isinstance(task, SceneTask):
            px = camera_px or task.config.image_size
            self._overview = VideoRenderer(task.scene.model, oh, ow)
            self._cameras = task.camera_renderer(px, px)
            self._camera_ids = [robot.camera_id for robot in task.agent_robots]
            self._camera_buf = np.empty((n, px, px, self.channels.planes), self.channels.dtype)
            self._upscale = np.arange(grid.tile) * px // grid.tile
            self._data = task.scene.data
        self._sprites: dict[str, np.ndarray] = {}

    @classmethod
    def of_env(
        cls,
        env: OptionEnv,
        title: str | Sequence[str],
        camera_px: int | None = None,
        timeline_ticks: int | None = None,
    ) -> FrameComposer:
        """The composer of ``env``'s frames: its task, agents, options' colours and tick limit
        (a rollout video and the PettingZoo view's ``render()`` draw the same frame)."""
        return cls(
            env.task,
            env.spec.agent_names,
            title=title,
            max_ticks=env.spec.max_ticks,
            camera_px=camera_px,
            colours=option_colours(env.spec),
            timeline_ticks=timeline_ticks or min(env.spec.max_ticks, VIDEO_MAX_TICKS),
        )

    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.height, self.width, 3)

    def compose(self, overlay: Overlay) -> np.ndarray:
        """Render the current state and draw ``overlay``: uint8 ``[H, W, 3]`` (a copy)."""
        return self.compose_in_place(overlay).copy()

    def compose_in_place(self, overlay: Overlay, *, cameras: bool = True) -> np.ndarray:
        """:meth:`compose`, returning the composer's own frame (valid until the next call);
        ``cameras=False`` keeps the robots' tiles of the last frame (a video renders them
        once a tick)."""
        self._part(
            "panel",
            (overlay.tick, overlay.ret, overlay.reward, overlay.note, tuple(overlay.state)),
            lambda: self._draw_panel(overlay),
        )
        captions = (tuple(overlay.options), tuple(overlay.started), tuple(overlay.progress))
        self._part("captions", captions, lambda: self._draw_captions(overlay))
        rows = tuple(tuple(row) for row in overlay.timeline)
        self._part("timeline", (overlay.tick, rows), lambda: self._draw_timeline(overlay))
        self._draw_overview()
        if self.scene and (cameras or not self._drawn.get("tiles")):
            self._draw_tiles()
            self._drawn["tiles"] = True
        return self._canvas

    def _part(self, name: str, shows: object, draw: Callable[[], None]) -> None:
        """Redraw part ``name`` of the frame when what it ``shows`` changed."""
        if self._drawn.get(name) != shows:
            draw()
            self._drawn[name] = shows

    # --------------------------------------------------------------------------- the views
    def _draw_overview(self) -> None:
        """The overview (with its labels) or what a scene-less task draws, fit to size and
        centred."""
        oh, ow = OVERVIEW_SIZE
        region = self._canvas[:oh, :ow]
        if not self.scene:
            frame = self.task.video_frame()
            region[:] = BACKGROUND
            if frame is not None:
                picture = Image.fromarray(np.asarray(frame, dtype=np.uint8))
                scale = min(ow / picture.width, oh / picture.height)
                size = (max(1, int(picture.width * scale)), max(1, int(picture.height * scale)))
                resized = np.asarray(picture.resize(size, Image.NEAREST))
                left, top = (ow - size[0]) // 2, (oh - size[1]) // 2  # centred
                region[top : top + size[1], left : left + size[0]] = resized[..., :3]
            return
        if self.view is None:
            model = self.task.scene.model  # type: ignore[attr-defined]
            self.view = overview_view(model, self._data, ow / oh)
            self._overview.camera = self.view.free_camera(model)
        region[:] = self._overview.frame(self._data)
        if self.labels:
            self._draw_labels(region)

    def _draw_tiles(self) -> None:
        self._cameras.render(self._data, self._camera_ids, out=self._camera_buf)
        grid, up = self.grid, self._upscale
        for i in range(len(self.agent_names)):
            x, y = grid.cell(i, self.width)
            top = y + grid.caption
            for view, tile in enumerate(channel_tiles(self._camera_buf[i], self.channels)):
                left = x + grid.tile_left(view)
                self._canvas[top : top + grid.tile, left : left + grid.tile] = tile[up][:, up]

    def _sprite(self, text: str) -> np.ndarray:
        """A label's box with its text, drawn once per text."""
        if text not in self._sprites:
            font = _font(LABEL_FONT)
            left, top, right, bottom = font.getbbox(text)
            size = (right - left + 2 * LABEL_PAD, bottom - top + 2 * LABEL_PAD)
            image = Image.new("RGB", size, LABEL_BOX)
            ImageDraw.Draw(image).text((LABEL_PAD - left, LABEL_PAD - top), text, TEXT, font)
            self._sprites[text] = np.asarray(image)
        return self._sprites[text]

    def _draw_labels(self, region: np.ndarray) -> None:
        """The task's labels on the overview (``region``): a dot on each labelled point, its
        text in a box nearby (:func:`~maopg.env.labels.place_labels`: apart and inside), and a
        line from the point to a box that had to move away from it; a point outside the
        picture is not labelled."""
        labels = self.task.labels()  # type: ignore[attr-defined]  (self.labels: a scene task)
        if not labels or self.view is None:
            return
        oh, ow = OVERVIEW_SIZE
        points = np.array([xyz for _, xyz in labels], dtype=np.float64)
        pixels = self.view.project(points, oh, ow)
        tops = self.view.project(points + np.array([0.0, 0.0, LABEL_OVER]), oh, ow)
        sprites = [self._sprite(text) for text, _ in labels]
        sizes = [(s.shape[1], s.shape[0]) for s in sprites]
        spots = place_labels(pixels, sizes, ow, oh, tops)
        for sprite, spot, (px, py) in zip(sprites, spots, pixels, strict=True):
            if spot is None:
                continue
            h, w = sprite.shape[:2]
            x, y = spot
            near_x, near_y = min(max(px, x), x + w - 1), min(max(py, y), y + h - 1)
            if np.hypot(near_x - px, near_y - py) > 8:
                _line(region, (px, py), (near_x, near_y), TEXT)
            region[y : y + h, x : x + w] = sprite
        for spot, (px, py) in zip(spots, pixels, strict=True):
            if spot is not None:
                cx, cy = int(min(max(px, 2), ow - 3)), int(min(max(py, 2), oh - 3))
                region[cy - 2 : cy + 3, cx - 2 : cx + 3] = LABEL_BOX
                region[cy - 1 : cy + 2, cx - 1 : cx + 2] = TEXT

    # --------------------------------------------------------------- what changes with ticks
    def _image(self, box: tuple[int, int, int, int]) -> tuple[Image.Image, ImageDraw.ImageDraw]:
        left, top, right, bottom = box
        image = Image.new("RGB", (right - left, bottom - top), BACKGROUND)
        return image, ImageDraw.Draw(image)

    def _paste(self, image: Image.Image, left: int, top: int) -> None:
        self._canvas[top : top + image.height, left : left + image.width] = np.asarray(image)

    def _draw_panel(self, overlay: Overlay) -> None:
        """Title, tick, return and last reward, the task's state, the legend."""
        left = OVERVIEW_SIZE[1]
        image, draw = self._image((left, 0, self.width, OVERVIEW_SIZE[0]))
        small, font = _font(15), _font(18)
        x, y, width = 12, 12, PANEL_WIDTH - 24
        for line in self.title:
            draw.text((x, y), fit(draw, line, width, small), fill=DIM, font=small)
            y += 21
        y += 4
        limit = f" / {self.max_ticks}" if self.max_ticks else ""
        last = "" if overlay.reward is None else f" (last tick {overlay.reward:+.1f})"
        head = [(f"tick {overlay.tick}{limit}", TEXT), (f"return {overlay.ret:+.1f}{last}", TEXT)]
        if overlay.note:
            head.append((overlay.note, HIGHLIGHT))
        for text, colour in head:
            draw.text((x, y), fit(draw, text, width, font), fill=colour, font=font)
            y += 26
        y += 6
        draw_items(draw, overlay.state, (x, y, x + width, LEGEND_TOP - 4), small, _font(13))
        y = LEGEND_TOP
        for colour, text in LEGEND:
            draw.rectangle((x, y + 4, x + 10, y + 14), fill=colour)
            draw.text((x + 16, y), text, fill=colour, font=small)
            y += 21
        self._paste(image, left, 0)

    def _draw_captions(self, overlay: Overlay) -> None:
        """Each robot's name, option and the ticks it has run, highlighted on the tick the
        robot chose it."""
        grid, small = self.grid, _font(15)
        for i, name in enumerate(self.agent_names):
            x, y = grid.cell(i, self.width)
            image, draw = self._image((x, y, x + grid.side, y + grid.caption))
            colour = HIGHLIGHT if overlay.started[i] else TEXT
            option = str(overlay.options[i])
            if overlay.progress and overlay.progress[i]:
                k = overlay.progress[i]
                option += f", {k} tick{'s' if k != 1 else ''}"
            if grid.two_lines:
                for k, text in enumerate((name, option)):
                    text = fit(draw, text, grid.side - 4, small)
                    draw.text((2, 2 + 20 * k), text, fill=colour, font=small)
            else:
                text = fit(draw, f"{name}: {option}", grid.side - 4, small)
                draw.text((2, 4), text, fill=colour, font=small)
            self._paste(image, x, y)

    def _draw_timeline(self, overlay: Overlay) -> None:
        n, top, margin = len(self.agent_names), self.timeline_top, 12
        image, draw = self._image((0, top, self.width, top + timeline_height(n)))
        box = (margin, 2, self.width - margin, image.height - 2)
        ticks = max(self.timeline_ticks, overlay.tick)
        rows = overlay.timeline or [()] * n
        font = _font(TIMELINE_PITCH[n > 4] - 4)  # the text fits its row's bar
        draw_timeline(draw, box, self.agent_names, rows, ticks, overlay.tick, self.colours, font)
        self._paste(image, 0, top)

    def close(self) -> None:
        if self.scene:
            self._overview.close()
            self._cameras.close()


def _line(region: np.ndarray, a: tuple[float, float], b: tuple[float, float], colour) -> None:
    """A one-pixel line from ``a`` to ``b`` (x, y), clipped to ``region``."""
    steps = int(max(abs(b[0] - a[0]), abs(b[1] - a[1]))) + 1
    xs = np.linspace(a[0], b[0], steps).round().astype(int)
    ys = np.linspace(a[1], b[1], steps).round().astype(int)
    keep = (xs >= 0) & (xs < region.shape[1]) & (ys >= 0) & (ys < region.shape[0])
    region[ys[keep], xs[keep]] = colour


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
    fps: int = FPS,
    frames_per_tick: int = FRAMES_PER_TICK,
    camera_px: int | None = None,
    max_ticks: int | None = None,
    policy_label: str = "",
    progress: bool = False,
) -> RecordedEpisode:
    """Play one episode of ``env``'s task with ``policy`` and write it to ``path`` (MP4).

    One frame at reset and ``frames_per_tick`` for every tick, so ``frames == 1 +
    frames_per_tick * ticks``: a scene task's are the physics states inside the tick and the
    one it ends in, a task without a scene shows the tick's end as many times. ``policy`` maps
    a :class:`DecisionPoint` to a joint option (a reference policy or :class:`eval` 's adapter
    of a trained network). A scene task is filmed by its framed overview; any other task by its
    ``video_frame`` hook, or as its state panel alone. Recording changes nothing of the
    episode: the same seed plays the same ticks, filmed or not.

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

    if frames_per_tick < 1:
        raise ValueError(f"frames_per_tick must be at least 1, got {frames_per_tick}")
    path = Path(path)
    if path.suffix.lower() != ".mp4":  # before anything is written: ffmpeg would leave a stub
        raise ValueError(f"video path {path}: must end in .mp4 (an H.264 MP4 is written)")
    task = env.task
    n = env.num_agents
    limit = VIDEO_MAX_TICKS if max_ticks is None else max_ticks
    bounded = min(limit, env.spec.max_ticks)
    title = video_title(task.name, env.strategy.value, policy_label, seed)
    composer = FrameComposer.of_env(env, title, camera_px, timeline_ticks=bounded)
    path.parent.mkdir(parents=True, exist_ok=True)
    timeline = TimelineRecorder(n)
    started = np.zeros(n, dtype=bool)
    total = [0.0]
    shown: list[Overlay] = []  # the last tick's overlay
    inside = [0]  # frames written inside the tick in progress
    writer = imageio.get_writer(
        path, fps=fps, codec="libx264", macro_block_size=BLOCK, output_params=list(ENCODER)
    )
    frames = [0]
    bar = tqdm(
        total=bounded,
        desc=f"video {path.name}",
        unit="tick",
        disable=not shows_bar(progress),
        leave=False,
    )

    def write(overlay: Overlay, times: int = 1, cameras: bool = True) -> None:
        frame = composer.compose_in_place(overlay, cameras=cameras)
        for _ in range(times):
            writer.append_data(frame)
        frames[0] += times

    def tick_overlay(reward: float | None, note: str = "") -> Overlay:
        options = env.running_option_names()
        return Overlay(
            tick=task.ticks,
            ret=total[0],
            reward=reward,
            options=options,
            started=started.tolist(),
            state=panel_items(task.name, task.describe()),
            note=note,
            progress=timeline.progress(options, task.ticks),
            timeline=timeline.rows(),
        )

    def on_substep() -> None:
        # the physics of tick task.ticks + 1, with the options chosen for it
        options = env.running_option_names()
        doing = timeline.progress(options, task.ticks + 1)
        overlay = replace(shown[0], options=options, started=started.tolist(), progress=doing)
        write(overlay, cameras=False)
        inside[0] += 1

    def on_tick(tick_env: OptionEnv, reward: float) -> None:
        timeline.on_tick(tick_env, reward)
        total[0] += reward
        cut = goes_on_past(tick_env, limit)
        shown[0] = tick_overlay(reward, "video cut (episode goes on)" if cut else "")
        write(shown[0], max(1, frames_per_tick - inside[0]))
        inside[0] = 0
        bar.update()
        started[:] = False
        if cut:
            raise TickLimit

    env.add_tick_listener(on_tick)
    if isinstance(task, SceneTask) and frames_per_tick > 1:
        task.scene.watch_substeps(frames_per_tick, on_substep)
    try:
        point: DecisionPoint = env.reset(seed=seed)
        shown.append(tick_overlay(None))
        write(shown[0])
        while not point.done:
            joint = np.asarray(policy(point))
            started[:] = point.choosing
            timeline.decide(point)
            point = env.step(joint)
    except TickLimit:
        return RecordedEpisode(path, frames[0], composer.shape, total[0], limit, False, cut=True)
    finally:
        env.remove_tick_listener(on_tick)
        if isinstance(task, SceneTask):
            task.scene.watch_substeps(1, None)
        bar.close()
        writer.close()
        composer.close()
    episode = point.info["episode"]
    return RecordedEpisode(
        path, frames[0], composer.shape, episode["return"], episode["ticks"], episode["solved"]
    )
