"""An episode's option timeline (:mod:`maopg.env.timeline`) and its strip under the video, on
real episodes."""

from __future__ import annotations

import itertools

import numpy as np

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.env.timeline import IDLE, IDLE_COLOUR, option_colours, play_timeline


def _choices(env, policy, seed, ticks):
    """Per agent, the ticks of the decision points where it chose (a plain rollout)."""
    chosen = [[] for _ in range(env.num_agents)]

    def on_step(point):
        if not point.done:
            for i in np.flatnonzero(point.choosing):
                chosen[i].append(point.ticks)

    run_episode(env, policy, seed=seed, on_step=on_step)
    return chosen


def test_segments_cover_the_episode_and_start_where_their_agent_chose():
    env = make_env("tool_delivery", "continue", seed=0, overrides={"max_ticks": 30})
    try:
        played = play_timeline(env, RandomPolicy(env.spec, 5), seed=5, max_ticks=1000)
        chosen = _choices(env, RandomPolicy(env.spec, 5), 5, 30)
    finally:
        env.close()
    assert played.ticks == 30 and not played.cut and len(played.rows) == 3
    for row, ticks in zip(played.rows, chosen, strict=True):
        assert row[0].start == 0 and row[-1].end == 30
        for a, b in itertools.pairwise(row):
            assert a.end == b.start and a.start < a.end  # contiguous, none empty
        assert [s.start for s in row if s.chosen] == ticks  # one segment per decision
        assert all(s.option != IDLE for s in row)  # nobody idles under "continue"


def test_idle_stretches_under_all_are_segments_of_their_own_and_no_choice():
    env = make_env("tool_delivery", "all", seed=0, overrides={"max_ticks": 40})
    try:
        played = play_timeline(env, RandomPolicy(env.spec, 1), seed=1, max_ticks=25)
        colours = option_colours(env.spec)
    finally:
        env.close()
    assert played.cut and played.ticks == 25  # cut at max_ticks: the episode went on
    idle = [s for row in played.rows for s in row if s.option == IDLE]
    assert idle and not any(s.chosen for s in idle)
    assert colours[IDLE] == IDLE_COLOUR and colours["GoToWS"] != colours["GetTool"]
    assert len(set(colours.values())) == len(colours)  # Tool Delivery's options fit the palette


def test_the_strip_under_the_video_draws_the_options_so_far(tmp_path):
    """The video's timeline strip: a coloured bar per option so far, up to the current tick."""
    from maopg.env.video import OVERVIEW_SIZE, FrameComposer, Overlay

    env = make_env("tool_delivery", "continue", seed=0, overrides={"max_ticks": 40})
    try:
        played = play_timeline(env, reference_policy("scripted", env), seed=0, max_ticks=20)
        composer = FrameComposer.of_env(env, "t")
        try:
            n = env.num_agents
            base = dict(ret=0.0, reward=None, options=["-"] * n, started=[False] * n, state=[])
            empty = composer.compose(Overlay(tick=20, **base))
            drawn = composer.compose(Overlay(tick=20, timeline=played.rows, **base))
        finally:
            composer.close()
        colours = option_colours(env.spec)
    finally:
        env.close()
    strip = drawn[composer.timeline_top :]
    assert np.array_equal(drawn[: composer.timeline_top], empty[: composer.timeline_top])
    for row in played.rows:
        for segment in row:
            assert np.all(strip == colours[segment.option], axis=-1).sum() > 20, segment
    assert drawn.shape[0] > OVERVIEW_SIZE[0]
