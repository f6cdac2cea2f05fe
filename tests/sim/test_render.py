"""Headless camera rendering on real scenes: shapes, content, buffers, sizes, projection,
threads."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import threading
import time

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import numpy as np
import pytest

from maopg.sim.render import CameraRenderer, VideoRenderer, project_points
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


def test_video_renderer_frames_the_overview_fast_or_with_mujocos_defaults(td_scene) -> None:
    scene = td_scene()
    with VideoRenderer(scene.model, 120, 160) as video:
        frame = video.frame(scene.data)
        again = video.frame(scene.data)
    with VideoRenderer(scene.model, 120, 160, fast=False) as nice:
        shaded = nice.frame(scene.data)
    assert frame.shape == shaded.shape == (120, 160, 3) and frame.std() > 5.0
    assert frame is not again and np.array_equal(frame, again)
    assert not np.array_equal(frame, shaded)  # shadows and multisampling show
    assert scene.model.vis.quality.offsamples == 4, "the observation setting must not leak"


def test_a_point_on_the_optical_axis_projects_to_the_centre_and_behind_is_nan(td_scene) -> None:
    scene = td_scene()
    cam = scene.model.camera("overview").id
    eye, axes = scene.data.cam_xpos[cam], scene.data.cam_xmat[cam].reshape(3, 3)
    ahead, behind = eye - 5.0 * axes[:, 2], eye + 5.0 * axes[:, 2]
    up = ahead + 0.5 * axes[:, 1]  # camera +y: up in the image, a smaller row
    right = ahead + 0.5 * axes[:, 0]
    pixels = project_points(
        scene.model, scene.data, "overview", [ahead, behind, up, right], 120, 160
    )
    assert pixels[0] == pytest.approx([80.0, 60.0])
    assert np.isnan(pixels[1]).all()
    assert pixels[2, 0] == pytest.approx(80.0) and pixels[2, 1] < 60.0
    assert pixels[3, 1] == pytest.approx(60.0) and pixels[3, 0] > 80.0
    # half the vertical field of view away from the axis is the image's top edge
    tan = np.tan(np.radians(scene.model.cam_fovy[cam]) / 2)
    edge = ahead + 5.0 * tan * axes[:, 1]
    assert project_points(scene.model, scene.data, cam, edge, 120, 160)[0] == pytest.approx([80, 0])


def test_a_robot_is_drawn_where_its_body_projects(td_scene) -> None:
    """Moving a Turtlebot changes the rendered overview only near its projected positions,
    before and after: the projection agrees with MuJoCo's own camera."""
    height, width = 120, 160
    scenes = [td_scene(), td_scene(tb0=(5.5, 1.2))]
    with CameraRenderer(scenes[0].model, height, width) as renderer:
        before = renderer.render(scenes[0].data, ["overview"])[0].astype(int)
    with CameraRenderer(scenes[1].model, height, width) as renderer:
        after = renderer.render(scenes[1].data, ["overview"])[0].astype(int)
    spots = [
        project_points(
            s.model,
            s.data,
            "overview",
            s.data.xpos[s.robots["turtlebot0"].root_body_id],
            height,
            width,
        )[0]
        for s in scenes
    ]
    changed = np.argwhere(np.abs(after - before).sum(-1) > 30)[:, ::-1]  # (x, y)
    assert len(changed) > 20
    near = [np.linalg.norm(changed - spot, axis=1) for spot in spots]
    assert all(d.min() < 4 for d in near), "each position shows the robot at its projection"
    assert (np.minimum(*near) < 15).mean() > 0.95, "and nothing changed elsewhere"


def test_threads_never_draw_at_the_same_time_and_each_gets_its_own_images(td_scene) -> None:
    """Two threads render their own scenes at once (as the ``threads`` backend does): the GL
    draws never overlap (Mesa's llvmpipe crashed when they did), and each thread's images are
    the ones its scene gives rendered alone."""
    scenes = [td_scene(), td_scene(tb0=(2.0, 1.0))]
    alone = []
    for scene in scenes:
        with CameraRenderer(scene.model, 36, 36) as renderer:
            alone.append(renderer.render(scene.data, CAMERAS[:3]))
    inside, most = [0], [0]
    count = threading.Lock()

    def work(k: int, start: threading.Barrier, images: list) -> None:
        with CameraRenderer(scenes[k].model, 36, 36) as renderer:
            draw = renderer._renderer.render

            def counted(**kwargs):
                with count:
                    inside[0] += 1
                    most[0] = max(most[0], inside[0])
                try:
                    time.sleep(0.002)  # widen the window in which an overlap would show
                    return draw(**kwargs)
                finally:
                    with count:
                        inside[0] -= 1

            renderer._renderer.render = counted
            start.wait()
            for _ in range(20):
                images.append(renderer.render(scenes[k].data, CAMERAS[:3]))

    start = threading.Barrier(2)
    images: list[list] = [[], []]
    threads = [threading.Thread(target=work, args=(k, start, images[k])) for k in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert most[0] == 1
    for k in range(2):
        assert len(images[k]) == 20
        assert all(np.array_equal(image, alone[k]) for image in images[k])
