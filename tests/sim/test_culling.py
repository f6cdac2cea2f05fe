"""View-frustum culling draws the same observation frames, to the last bit, in less time."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import mujoco
import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, decision_points
from maopg.sim.culling import cull_outside_view
from maopg.sim.render import CameraRenderer, make_renderer

STEPS = 60
"""Decision points per task: both tasks' robots turn and cross their rooms in that many."""


def _frames_both_ways(task: str, height: int, width: int, aspect_error: float = 1.0):
    """Each robot camera at each of ``STEPS`` random decision points, drawn whole and culled
    (with the culling's aspect ratio off by ``aspect_error``): (whole, culled, culled counts)."""
    env = make_env(task, seed=3)
    scene = env.task.scene
    cameras = [robot.camera_id for robot in env.task.agent_robots]
    renderer = make_renderer(scene.model, height, width, shadows=False, offsamples=0)
    whole, culled, counts = [], [], []
    try:
        for _ in decision_points(env, RandomPolicy(env.spec, seed=3), STEPS):
            for camera in cameras:
                renderer.update_scene(scene.data, camera=camera)
                whole.append(renderer.render().copy())
                renderer.update_scene(scene.data, camera=camera)
                counts.append(cull_outside_view(renderer.scene, aspect_error * width / height))
                culled.append(renderer.render().copy())
    finally:
        renderer.close()
        env.close()
    return np.stack(whole), np.stack(culled), np.array(counts), scene.model.ngeom


@pytest.mark.parametrize(
    ("task", "height", "width"), [("tool_delivery", 64, 64), ("water_filling", 48, 80)]
)
def test_culled_frames_are_identical_and_most_geoms_are_culled(task, height, width) -> None:
    whole, culled, counts, ngeom = _frames_both_ways(task, height, width)
    assert np.array_equal(whole, culled)
    assert counts.mean() > 0.5 * ngeom  # not a test that cannot fail: most geoms were skipped


def test_a_frustum_too_narrow_would_show_in_the_frames() -> None:
    """The comparison above can fail: with the frustum's width halved, geoms at the edges of
    the view are culled and the frames differ."""
    whole, culled, _, _ = _frames_both_ways("water_filling", 64, 64, aspect_error=0.5)
    assert not np.array_equal(whole, culled)


def test_camera_renderer_culls_observations_but_not_frames_with_shadows() -> None:
    env = make_env("water_filling", seed=0)
    scene = env.task.scene
    env.reset()
    camera = env.task.agent_robots[0].camera_id
    try:
        with CameraRenderer(scene.model, 64, 64) as fast:
            image = fast.render(scene.data, [camera])[0]
            drawn = fast._renderer.scene.geoms[: fast._renderer.scene.ngeom]
            skipped = sum(g.type == mujoco.mjtGeom.mjGEOM_NONE for g in drawn)
        with CameraRenderer(scene.model, 64, 64, fast=False) as nice:
            nice.render(scene.data, [camera])
            drawn = nice._renderer.scene.geoms[: nice._renderer.scene.ngeom]
            assert all(g.type != mujoco.mjtGeom.mjGEOM_NONE for g in drawn)
    finally:
        env.close()
    assert skipped > 0 and image.std() > 5.0
