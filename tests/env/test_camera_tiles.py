"""A video's robot tiles show each camera channel: colour, depth in grey, classes in the
fixed palette, side by side, within the frame's width."""

from __future__ import annotations

import numpy as np

from maopg.env import make_env
from maopg.env.camera_tiles import FIXED_COLOURS, channel_tiles, class_colours
from maopg.env.video import ROW_WIDTH, TILE, FrameComposer, Overlay, tile_grid
from maopg.sim.channels import ImageChannels
from maopg.sim.segmentation import FIXED_CLASSES


def test_every_channel_has_a_tile_beside_the_colour_one():
    overrides = {"camera_channels": "rgb+depth+seg", "max_ticks": 4}
    env = make_env("water_filling", images=True, image_size=36, overrides=overrides)
    try:
        point = env.reset(seed=0)
        composer = FrameComposer(env.task, env.spec.agent_names, title="t", camera_px=36)
        try:
            base = dict(tick=0, ret=0.0, reward=None, options=["-", "-"], state=["s"])
            frame = composer.compose(Overlay(started=[False, False], **base))
        finally:
            composer.close()
    finally:
        env.close()
    grid, channels = composer.grid, env.spec.image_channels
    assert grid.views == 3 and grid.row_width <= ROW_WIDTH
    palette = class_colours(len(channels.classes))
    for agent in range(2):
        x, y = grid.cell(agent, frame.shape[1])
        top = y + grid.caption
        colour, depth, seg = (
            frame[top : top + grid.tile, x + left : x + left + grid.tile]
            for left in (grid.tile_left(v) for v in range(3))
        )
        assert colour.std() > 5 and depth.std() > 5
        assert np.all(depth == depth[..., :1]), "depth is grey"
        assert {tuple(c) for c in seg.reshape(-1, 3)} <= {tuple(c) for c in palette}
        # the tiles are the observation's channels, upscaled
        expected = channel_tiles(point.images[agent], channels)[2]
        assert {tuple(c) for c in seg.reshape(-1, 3)} == {tuple(c) for c in expected.reshape(-1, 3)}


def test_depth_is_white_at_near_and_black_at_far():
    channels = ImageChannels(("depth",), (0.5, 4.5))
    image = np.array([[[0.5], [2.5]], [[4.5], [9.0]]], dtype=np.float32)
    (tile,) = channel_tiles(image, channels)
    assert tile[..., 0].tolist() == [[255, 128], [0, 0]]


def test_the_fixed_classes_keep_their_colours_in_every_task():
    assert len(FIXED_COLOURS) == len(FIXED_CLASSES)
    assert (class_colours(9)[:5] == class_colours(7)[:5]).all()
    assert len({tuple(c) for c in class_colours(13)}) == 13


def test_cells_of_several_tiles_still_fit_the_frame():
    for views in (1, 2, 3):
        for agents in (1, 2, 3, 5, 8, 16):
            grid = tile_grid(agents, cameras=True, views=views)
            assert grid.row_width <= ROW_WIDTH and grid.cols * grid.rows >= agents
    assert tile_grid(3, cameras=True, views=1).tile == TILE  # the default layout as it was
