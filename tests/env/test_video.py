"""Headless rollout videos on the real scenes: frame count, size, overlay, seed, labels."""

from __future__ import annotations

import hashlib
import itertools

import imageio.v2 as imageio
import numpy as np
import pytest

from maopg.env import make_env, video
from maopg.env.panel import BAR, NOTHING, panel_items
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.env.video import (
    BACKGROUND,
    BLOCK,
    CAPTION,
    FRAMES_PER_TICK,
    GAP,
    HIGHLIGHT,
    LEGEND,
    LEGEND_TOP,
    OVERVIEW_SIZE,
    PANEL_WIDTH,
    ROW_WIDTH,
    TILE,
    FrameComposer,
    Overlay,
    record_episode,
    tile_grid,
    timeline_height,
    video_title,
)
from maopg.sim.framing import overview_view
from maopg.tasks.panel import Field, Gauge, Heading
from maopg.tasks.text import generic_state_lines


def _read(path):
    reader = imageio.get_reader(path)
    try:
        return np.stack(list(reader.iter_data()))  # len(reader) is inf
    finally:
        reader.close()


def _short_env(seed: int = 0):
    return make_env("tool_delivery", "continue", seed=seed, overrides={"max_ticks": 12})


def test_short_rollout_writes_four_frames_per_tick(tmp_path):
    env = _short_env()
    try:
        result = record_episode(env, RandomPolicy(env.spec, 1), tmp_path / "v.mp4", seed=1, fps=5)
    finally:
        env.close()
    assert FRAMES_PER_TICK == 4
    assert result.ticks == 12 and result.frames == 4 * result.ticks + 1
    frames = _read(result.path)
    assert frames.shape == (49, *result.shape)
    height, width, _ = result.shape
    assert height % BLOCK == 0 and width % BLOCK == 0  # the writer never had to resize
    assert height >= OVERVIEW_SIZE[0] + CAPTION and width >= OVERVIEW_SIZE[1]
    overview = frames[:, : OVERVIEW_SIZE[0], : OVERVIEW_SIZE[1]].astype(np.int16)
    assert overview[0].std() > 20  # a rendered scene, not a blank image
    # robots drive: the overview changes between the first and the last frame
    assert np.abs(overview[-1] - overview[0]).mean() > 0.5


def test_water_filling_video_shows_both_robots(tmp_path):
    env = make_env("water_filling", "continue", seed=0, overrides={"max_ticks": 6})
    try:
        result = record_episode(env, RandomPolicy(env.spec, 0), tmp_path / "wf.mp4", seed=0)
    finally:
        env.close()
    frames = _read(result.path)
    assert frames.shape == (25, *result.shape)
    tiles = frames[:, OVERVIEW_SIZE[0] + CAPTION : OVERVIEW_SIZE[0] + CAPTION + TILE]
    assert tiles[0].std() > 10  # the robots' camera tiles are rendered


def test_same_seed_gives_the_same_video(tmp_path):
    digests = []
    for name in ("a.mp4", "b.mp4"):
        env = _short_env()
        try:
            record_episode(env, RandomPolicy(env.spec, 7), tmp_path / name, seed=7)
        finally:
            env.close()
        digests.append(hashlib.sha256((tmp_path / name).read_bytes()).hexdigest())
    assert digests[0] == digests[1]


def test_caption_highlights_agents_that_start_an_option():
    env = _short_env()
    try:
        composer = FrameComposer(env.task, env.spec.agent_names, title="t", max_ticks=12)
        try:
            base = dict(
                tick=3, ret=-3.0, reward=-1.0, options=["GoToWS", "GetTool", "Wait"], state=["s"]
            )
            plain = composer.compose(Overlay(started=[False, False, False], **base))
            marked = composer.compose(Overlay(started=[False, True, False], **base))
        finally:
            composer.close()
    finally:
        env.close()
    assert plain.shape == composer.shape
    caption = slice(OVERVIEW_SIZE[0] + GAP, OVERVIEW_SIZE[0] + GAP + CAPTION)

    def yellow(frame):
        return np.all(frame[caption] == HIGHLIGHT, axis=-1)

    assert not yellow(plain).any()
    cols = np.flatnonzero(yellow(marked).any(axis=0))
    assert cols.size > 0
    # only the second agent's caption (the middle tile) is highlighted
    third = composer.width / 3
    assert cols.min() > third * 0.9 and cols.max() < 2 * third * 1.1
    # everything outside the captions (renders, panel) is identical
    outside = np.ones(plain.shape[:2], bool)
    outside[caption] = False
    assert np.array_equal(plain[outside], marked[outside])


def test_panel_shows_the_last_tick_reward():
    """The last tick's reward is drawn in the side panel, and nowhere else."""
    env = _short_env()
    try:
        composer = FrameComposer(env.task, env.spec.agent_names, title="t", max_ticks=12)
        try:
            base = dict(tick=3, ret=97.0, options=["-"] * 3, started=[False] * 3, state=["s"])
            frames = [
                composer.compose(Overlay(reward=reward, **base)) for reward in (-1.0, 99.0, None)
            ]
        finally:
            composer.close()
    finally:
        env.close()
    panel = np.zeros(frames[0].shape[:2], bool)
    panel[: OVERVIEW_SIZE[0], OVERVIEW_SIZE[1] :] = True
    for a, b in ((0, 1), (0, 2), (1, 2)):
        assert not np.array_equal(frames[a][panel], frames[b][panel])
        assert np.array_equal(frames[a][~panel], frames[b][~panel])


def test_overlay_rewards_are_the_tick_rewards(tmp_path, monkeypatch):
    """Per tick: the reward of its tick, and the return so far; they add up to the episode's.
    The frames inside a tick show the last tick's figures."""
    overlays = []
    compose = FrameComposer.compose_in_place

    def spy(self, overlay, **kwargs):
        overlays.append(overlay)
        return compose(self, overlay, **kwargs)

    monkeypatch.setattr(FrameComposer, "compose_in_place", spy)
    env = _short_env()
    ticks = []
    env.add_tick_listener(lambda _env, reward: ticks.append(reward))
    try:
        result = record_episode(env, RandomPolicy(env.spec, 1), tmp_path / "v.mp4", seed=1)
    finally:
        env.close()
    assert len(overlays) == result.frames == 4 * len(ticks) + 1  # Tool Delivery: 50 steps a tick
    ends = overlays[::4]  # the reset frame, then each tick's last
    assert [o.tick for o in ends] == list(range(result.ticks + 1))
    assert [o.tick for o in overlays[1::4]] == list(range(result.ticks))  # inside the next tick
    assert ends[0].reward is None and ends[0].ret == 0.0
    rewards = [o.reward for o in ends[1:]]
    assert rewards == ticks
    assert len(set(rewards)) > 1  # not a constant: the random episode has more than tick costs
    assert [o.ret for o in ends[1:]] == pytest.approx(np.cumsum(rewards).tolist())
    assert sum(rewards) == pytest.approx(result.ret)
    assert ends[-1].ret == pytest.approx(result.ret)


def test_panel_items_are_the_tasks_named_quantities():
    td = panel_items(
        "tool_delivery",
        {"human_stage": 1, "staged": [2], "carried": [[1], []], "delivered": [True, False, False]},
    )
    assert td == [
        Heading("humans: tools received"),
        Gauge("human", 1 / 3, "1/3, needs tool 1"),
        Heading("who carries what"),
        Field("turtlebot0", "tool 1"),
        Field("turtlebot1", "nothing"),
        Field("desk", "tool 2"),
        Field("delivered", "tool 0"),
    ]
    wf = {"levels": [0.25, 1.0], "known_levels": [0.5, 1.0], "elapsed": [4, 0], "fills": 1}
    assert panel_items("water_filling", wf) == [
        Heading("jar levels (| = last seen)"),
        Gauge("jar 0", 0.25, "0.25, seen 4 ago", mark=0.5),
        Gauge("jar 1", 1.0, "1.00, seen 0 ago", mark=1.0),
        Field("fills", "1"),
    ]
    # a task without a panel: its describe() as lines
    assert generic_state_lines({"jar_levels": [0.5, 1.0, 0.125]}) == [
        "jar levels: [0.50, 1.00, 0.12]"
    ]
    assert panel_items("other_task", {"ticks": 3}) == ["ticks: 3"]
    assert panel_items("other_task", {}) == [NOTHING]  # a task that describes nothing


def test_the_panel_draws_a_bar_per_jar_filled_to_its_level():
    """Water Filling's panel: a jar's bar grows with its level, its mark moves with the level
    the robots last saw, and nothing outside the panel changes."""
    env = make_env("water_filling", "continue", seed=0, overrides={"max_ticks": 6})
    frames = []
    try:
        env.reset(seed=0)
        for level, seen in ((0.2, 1.0), (0.9, 1.0), (0.9, 0.5)):
            state = {
                "levels": [level, 1.0, 1.0],
                "known_levels": [seen, 1.0, 1.0],
                "elapsed": [0, 0, 0],
                "fills": 0,
            }
            overlay = _overlay(3, state=panel_items("water_filling", state))
            frames.append(_compose(env, overlay))
    finally:
        env.close()
    panel = np.zeros(frames[0].shape[:2], bool)
    panel[: OVERVIEW_SIZE[0], OVERVIEW_SIZE[1] :] = True
    for a, b in ((0, 1), (1, 2)):
        changed = np.any(frames[a] != frames[b], axis=-1)
        assert changed.any() and not changed[~panel].any()

    def filled(frame):  # the bars' pixels in the panel
        return np.all(frame[panel] == BAR, axis=-1).sum()

    assert filled(frames[1]) > filled(frames[0]) + 30  # 0.9 vs 0.2 of jar 0's bar
    # the mark moved, not the level: only the pixels of the 3 px wide mark differ
    assert abs(filled(frames[1]) - filled(frames[2])) <= 3 * 11


def test_cli_records_the_scripted_episode(tmp_path, capsys, monkeypatch, terminal):
    out = tmp_path / "td.mp4"
    from maopg.experiment.cli.eval_cli import main

    titles = []
    monkeypatch.setattr(video, "video_title", lambda *a: titles.append(a) or video_title(*a))
    main(["video", "--reference", "scripted", "--task", "tool_delivery", "--out", str(out)])
    printed = capsys.readouterr()
    assert "return 259.0 in 41 ticks" in printed.out
    assert "video td.mp4" in printed.err and "tick" in printed.err  # the progress bar
    assert len(_read(out)) == 4 * 41 + 1
    assert titles == [("tool_delivery", "continue", "scripted", 0)]


def test_recording_does_not_change_the_episode(tmp_path):
    """Under ``all`` (idling agents): same decisions, return, length and physics, tick by
    tick, as a plain rollout, though the video films inside every tick."""
    env = make_env("tool_delivery", "all", seed=0, overrides={"max_ticks": 25})
    states = []
    env.add_tick_listener(lambda e, _r: states.append(e.task.scene.state()["qpos"]))
    try:
        plain = run_episode(env, RandomPolicy(env.spec, 4), seed=2)
        filmed = len(states)
        video = record_episode(env, RandomPolicy(env.spec, 4), tmp_path / "all.mp4", seed=2)
    finally:
        env.close()
    assert (video.ret, video.ticks, video.solved) == (plain.ret, plain.ticks, plain.solved)
    assert video.frames == 4 * plain.ticks + 1
    assert len(states) == 2 * filmed
    assert all(np.array_equal(a, b) for a, b in zip(states[:filmed], states[filmed:], strict=True))


def test_the_frames_inside_a_tick_are_the_physics_states_it_passes_through(tmp_path, monkeypatch):
    """Four frames a tick, each rendered from the state the physics reached there: the
    overview changes from frame to frame inside a tick while the Turtlebots drive; a task
    without a scene shows its tick four times instead."""
    overviews = []
    compose = FrameComposer.compose_in_place

    def spy(self, overlay, **kwargs):
        frame = compose(self, overlay, **kwargs)
        overviews.append(frame[: OVERVIEW_SIZE[0], : OVERVIEW_SIZE[1]].astype(np.int16))
        return frame

    monkeypatch.setattr(FrameComposer, "compose_in_place", spy)
    env = make_env("tool_delivery", "continue", seed=0, overrides={"max_ticks": 3})
    try:
        video = record_episode(env, reference_policy("scripted", env), tmp_path / "td.mp4")
    finally:
        env.close()
    assert video.frames == len(overviews) == 1 + 4 * 3
    for a, b in itertools.pairwise(overviews[1:]):
        assert np.abs(a - b).max() > 50  # something moved between consecutive frames
    overviews.clear()
    grid = make_env("box_pushing_grid", "continue", seed=0, overrides={"max_ticks": 2})
    try:
        video = record_episode(grid, reference_policy("scripted", grid), tmp_path / "grid.mp4")
    finally:
        grid.close()
    assert video.frames == 1 + 4 * 2 and len(overviews) == 3  # drawn once a tick, shown 4 times


def test_a_big_team_gets_rows_of_smaller_tiles_each_with_its_caption():
    """Eight robots: two rows of 192 px tiles within the overview and panel's width; every
    caption drawn (highlighted when its robot starts an option) and every camera rendered."""
    overrides = {"vehicles": 4, "drones": 4, "jars": 8, "max_ticks": 6}
    env = make_env("water_filling", "continue", overrides=overrides)
    names = env.spec.agent_names
    try:
        env.reset(seed=0)
        composer = FrameComposer(env.task, names, title="t", max_ticks=6)
        try:
            base = dict(tick=0, ret=0.0, reward=None, options=["NavToFill(7)"] * 8, state=["s"])
            frame = composer.compose(Overlay(started=[True] * 8, **base))
            plain = composer.compose(Overlay(started=[False] * 8, **base))
        finally:
            composer.close()
    finally:
        env.close()
    grid = composer.grid
    assert (grid.side, grid.cols, grid.rows) == (192, 4, 2)
    height, width, _ = frame.shape
    assert width == ROW_WIDTH and height % BLOCK == 0 and width % BLOCK == 0
    strip = timeline_height(8)
    assert height <= OVERVIEW_SIZE[0] + 2 * (TILE + CAPTION + 2 * GAP) + strip + BLOCK
    for i in range(len(names)):
        x, y = grid.cell(i, width)
        caption = frame[y : y + grid.caption, x : x + grid.side]
        assert np.all(caption == HIGHLIGHT, axis=-1).sum() > 20, names[i]
        assert not np.all(plain[y : y + grid.caption, x : x + grid.side] == HIGHLIGHT, -1).any()
        tile = frame[y + grid.caption : y + grid.caption + grid.tile, x : x + grid.side]
        assert tile.shape == (192, 192, 3) and tile.std() > 5, names[i]
    below = frame[y + grid.caption + grid.tile : composer.timeline_top]
    assert below.size and np.all(below == BACKGROUND), "nothing between the tiles and timeline"


def test_tile_rows_stay_within_the_frame_width():
    for agents in (1, 3, 4, 7, 9, 16, 30):
        grid = tile_grid(agents, cameras=True)
        assert grid.row_width <= ROW_WIDTH and grid.cols * grid.rows >= agents
        assert (grid.rows == 1) == (agents <= 3) and (grid.side == TILE) == (agents <= 6)


def _overlay(n, **fields):
    """A fixed overlay for ``n`` agents, with ``fields`` changed."""
    base = dict(tick=0, ret=0.0, reward=None, options=["-"] * n, started=[False] * n, state=["s"])
    return Overlay(**{**base, **fields})


def _compose(env, overlay=None, **settings):
    """One frame of ``env``'s current state (a fixed overlay unless given)."""
    overlay = overlay or _overlay(len(env.spec.agent_names))
    composer = FrameComposer(env.task, env.spec.agent_names, **{"title": "t", **settings})
    try:
        return composer.compose(overlay)
    finally:
        composer.close()


def test_the_title_names_policy_and_both_seeds_and_is_drawn_only_at_the_panel_top():
    title = video_title("tool_delivery", "continue", "async seed 2 (sampled)", 0)
    assert title == ["tool_delivery | continue", "async seed 2 (sampled)", "episode seed 0"]
    assert video_title("t", "any", "", 5) == ["t | any", "episode seed 5"]
    env = _short_env()
    try:
        env.reset(seed=0)
        frames = [
            _compose(env, title=video_title("tool_delivery", "continue", who, 0))
            for who in ("async seed 2 (sampled)", "mac-dqn seed 1 (greedy)")
        ]
    finally:
        env.close()
    area = np.zeros(frames[0].shape[:2], bool)
    area[: 12 + 3 * 21, OVERVIEW_SIZE[1] :] = True  # the title's three lines
    assert not np.array_equal(frames[0][area], frames[1][area])
    assert np.array_equal(frames[0][~area], frames[1][~area])


def test_labels_are_drawn_at_the_robots_and_jars_projections():
    """Water Filling's overview labels each robot and jar at its projected position, and
    nothing else changes: the panel and the camera tiles are the same without labels."""
    env = make_env("water_filling", "continue", seed=0, overrides={"max_ticks": 6})
    try:
        env.reset(seed=0)
        labelled, plain = _compose(env), _compose(env, labels=False)
        labels = env.task.labels()
        scene = env.task.scene
        view = overview_view(scene.model, scene.data, OVERVIEW_SIZE[1] / OVERVIEW_SIZE[0])
        spots = view.project(np.array([xyz for _, xyz in labels]), *OVERVIEW_SIZE)
    finally:
        env.close()
    assert [text for text, _ in labels] == ["vehicle", "drone", "jar 0", "jar 1", "jar 2"]
    changed = np.any(labelled != plain, axis=-1)
    assert not changed[OVERVIEW_SIZE[0] :].any() and not changed[:, OVERVIEW_SIZE[1] :].any()
    ys, xs = np.nonzero(changed)
    for (text, _), (x, y) in zip(labels, spots, strict=True):
        assert 0 <= x < OVERVIEW_SIZE[1] and 0 <= y < OVERVIEW_SIZE[0], text
        near = (np.abs(xs - x) < 40) & (ys - y < 5) & (y - ys < 45)
        assert near.sum() > 50, f"{text} is labelled where it stands, just over it"
    # every changed pixel belongs to some label near its point (a dot, a box over it)
    close = np.zeros(len(xs), bool)
    for x, y in spots:
        close |= (np.abs(xs - x) < 60) & (ys - y < 5) & (y - ys < 45)
    assert close.all()


def test_labels_stay_inside_the_overview_for_a_big_team():
    overrides = {"vehicles": 4, "drones": 4, "jars": 8, "max_ticks": 6}
    env = make_env("water_filling", "continue", overrides=overrides)
    try:
        env.reset(seed=0)
        labelled, plain = _compose(env), _compose(env, labels=False)
        assert len(env.task.labels()) == 16
    finally:
        env.close()
    changed = np.any(labelled != plain, axis=-1)
    assert changed[: OVERVIEW_SIZE[0], : OVERVIEW_SIZE[1]].sum() > 16 * 100
    assert not changed[OVERVIEW_SIZE[0] :].any() and not changed[:, OVERVIEW_SIZE[1] :].any()


def test_the_legend_explains_the_caption_colours_at_the_panel_bottom():
    env = _short_env()
    try:
        env.reset(seed=0)
        frame = _compose(env)
    finally:
        env.close()
    x0 = OVERVIEW_SIZE[1]
    for k, (colour, text) in enumerate(LEGEND):
        row = frame[LEGEND_TOP + 21 * k : LEGEND_TOP + 21 * (k + 1), x0 : x0 + PANEL_WIDTH]
        assert np.all(row == colour, axis=-1).sum() > 100 + 5 * len(text), text
    assert "chose" in LEGEND[0][1] and LEGEND[0][0] == HIGHLIGHT
    # the legend is the panel's only highlighted text on a frame without a note
    panel = frame[:LEGEND_TOP, x0:]
    assert not np.all(panel == HIGHLIGHT, axis=-1).any()


def test_progress_bar_over_the_ticks_on_stderr(tmp_path, capsys, terminal):
    env = make_env("tool_delivery", "continue", overrides={"max_ticks": 4})
    try:
        record_episode(env, RandomPolicy(env.spec, 1), tmp_path / "p.mp4", seed=1, progress=True)
        assert "/4 " in capsys.readouterr().err  # total: the episode's bound, 4 ticks
        record_episode(env, RandomPolicy(env.spec, 1), tmp_path / "q.mp4", seed=1)
        assert capsys.readouterr().err == ""
    finally:
        env.close()


def test_labels_at_the_picture_edges_stay_inside_and_points_behind_are_skipped(monkeypatch):
    env = _short_env()
    try:
        env.reset(seed=0)
        data, model = env.task.scene.data, env.task.scene.model
        height, width = OVERVIEW_SIZE
        view = overview_view(model, data, width / height)  # what the video films
        eye, axes = view.pos, view.axes
        focal = 0.5 * height / np.tan(np.radians(view.fovy) / 2)

        def at(u, v):  # the world point 5 m deep that the overview shows at pixel (u, v)
            ray = (u - width / 2) / focal * axes[:, 0] - (v - height / 2) / focal * axes[:, 1]
            return eye + 5.0 * (ray - axes[:, 2])

        corners = [("corner", at(u, v)) for u in (0.5, width - 0.5) for v in (0.5, height - 0.5)]
        behind = [("behind", eye + axes[:, 2])]
        frames = {}
        for name, labels in (("none", []), ("corners", corners), ("behind", behind)):
            monkeypatch.setattr(type(env.task), "labels", lambda self, labels=labels: labels)
            frames[name] = _compose(env)
    finally:
        env.close()
    changed = np.any(frames["corners"] != frames["none"], axis=-1)
    inside = changed[:height, :width]
    assert changed.sum() == inside.sum() > 4 * 100, "drawn, and only inside the overview"
    for rows, cols in ((slice(0, 40), slice(0, 80)), (slice(-40, None), slice(-80, None))):
        assert inside[rows, cols].any(), "each corner's label is kept in the picture"
    assert np.array_equal(frames["behind"], frames["none"])
