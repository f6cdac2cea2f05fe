"""Headless camera rendering on real scenes: shapes, content, buffers, sizes."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import numpy as np
import pytest

from maopg.sim.render import CameraRenderer, VideoRenderer
from maopg.sim.scene import SceneBuilder

CAMERAS = ["turtlebot0/camera", "turtlebot1/camera", "fetch/camera", "overview"]


def test_cameras_give_distinct_non_constant_uint8_images(td_scene) -> None:
    scene = td_scene()
    with CameraRenderer(scene.model, 64, 64) as renderer:
        images = renderer.render(scene.data, CAMERAS)
    assert images.shape == (4, 64, 64, 3) and images.dtype == np.uint8
    for cam, image in zip(CAMERAS, images, strict=True):
        assert image.std() > 5.0, f"{cam} is flat"
    for i in range(len(CAMERAS)):
        for j in range(i + 1, len(CAMERAS)):
            assert not np.array_equal(images[i], images[j])


def test_preallocated_output_is_filled_in_place_and_follows_the_robot(td_scene) -> None:
    scene = td_scene()
    out = np.zeros((2, 48, 64, 3), dtype=np.uint8)
    with CameraRenderer(scene.model, 48, 64) as renderer:
        result = renderer.render(scene.data, ["turtlebot0/camera", 0], out=out)
        assert result is out and out.any()
        first = out[0].copy()
        scene.robots["turtlebot0"].drive_to((6.0, 3.0))
        scene.advance(1.0)
        renderer.render(scene.data, ["turtlebot0/camera", 0], out=out)
        assert not np.array_equal(first, out[0]), "the onboard camera must move with its robot"
        with pytest.raises(ValueError, match="shape"):
            renderer.render(scene.data, ["turtlebot0/camera"], out=out)


def test_render_larger_than_the_offscreen_buffer_is_handled() -> None:
    builder = SceneBuilder("arenas/tool_delivery.xml", timestep=0.02, video_size=(64, 64))
    builder.add_robot("fetch", "fetch", (0.9, 1.8, 0.0))
    scene = builder.build()
    assert scene.model.vis.global_.offwidth == 64
    with CameraRenderer(scene.model, 200, 300) as renderer:
        image = renderer.render(scene.data, ["overview"])[0]
    assert image.shape == (200, 300, 3) and image.std() > 5.0
    assert scene.model.vis.global_.offwidth >= 300 and scene.model.vis.global_.offheight >= 200


def test_video_renderer_frames_the_overview_with_the_nicer_settings(td_scene) -> None:
    scene = td_scene()
    with VideoRenderer(scene.model, 120, 160) as video:
        frame = video.frame(scene.data)
        again = video.frame(scene.data)
    assert frame.shape == (120, 160, 3) and frame.std() > 5.0
    assert frame is not again and np.array_equal(frame, again)
    assert scene.model.vis.quality.offsamples == 4, "the observation setting must not leak"
