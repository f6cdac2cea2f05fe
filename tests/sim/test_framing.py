"""The video's overview framed to the scene (:mod:`maopg.sim.framing`): everything of the
extent in the picture, the robots bigger than the arena's hand-placed camera shows them, and
MuJoCo's free camera drawing what the view projects."""

from __future__ import annotations  # noqa: I001  (maopg must come before mujoco)

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
import numpy as np
import pytest

from maopg.sim.framing import MARGIN, fit_view, level_axes, overview_view, scene_extent
from maopg.sim.render import CameraRenderer, VideoRenderer, View

HEIGHT, WIDTH = 120, 160


def test_the_fitted_view_holds_every_point_and_fills_one_direction() -> None:
    rng = np.random.default_rng(1)
    points = rng.uniform([-3, -2, 0], [4, 5, 1.5], size=(50, 3))
    axes = level_axes(np.array([0.0, 0.5, -0.866]))
    view = fit_view(points, axes, 45.0, WIDTH / HEIGHT)
    pixels = view.project(points, HEIGHT, WIDTH)
    assert np.isfinite(pixels).all()
    assert (pixels >= 0).all() and (pixels[:, 0] <= WIDTH).all() and (pixels[:, 1] <= HEIGHT).all()
    # the binding direction spans the picture less the margins, the other one is centred
    low, high = pixels.min(axis=0), pixels.max(axis=0)
    spans = (high - low) / [WIDTH, HEIGHT]
    assert spans.max() == pytest.approx(1 - MARGIN, abs=0.02)
    assert np.abs((low + high) / 2 - [WIDTH / 2, HEIGHT / 2]).min() < 1.0


def _robot_size(view: View, scene) -> float:
    """Pixels across the first robot's footprint in a 480 x 640 picture of ``view``."""
    base = scene.data.xpos[next(iter(scene.robots.values())).root_body_id]
    ring = base + 0.18 * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]])
    pixels = view.project(ring, 480, 640)
    return float(np.ptp(pixels, axis=0).max())


def test_the_overview_is_framed_to_the_scene_and_shows_the_robots_bigger(td_scene, wf_scene):
    """Water Filling's robots 1.5 times as big as its arena camera showed them; Tool
    Delivery's room is wider than the picture, whose width it already filled: a little."""
    for scene, gain in ((td_scene(), 1.08), (wf_scene(), 1.4)):
        view = overview_view(scene.model, scene.data, 640 / 480)
        corners = view.project(scene_extent(scene.model, scene.data), 480, 640)
        assert (corners >= -1e-6).all() and (corners <= [640, 480]).all()
        arena = View.of_camera(scene.model, scene.data, "overview")
        assert _robot_size(view, scene) > gain * _robot_size(arena, scene)
        forward = -view.axes[:, 2]
        assert np.allclose(forward, -arena.axes[:, 2], atol=1e-6)  # the arena's direction


def test_a_robot_is_drawn_where_the_framed_view_projects_it(td_scene) -> None:
    """MuJoCo's free camera at the view draws a moved Turtlebot where ``View.project`` puts
    it: the changed pixels lie around its projections before and after."""
    scenes = [td_scene(), td_scene(tb0=(5.5, 1.2))]
    view = overview_view(scenes[0].model, scenes[0].data, WIDTH / HEIGHT)
    frames = []
    for scene in scenes:
        with VideoRenderer(scene.model, HEIGHT, WIDTH, view) as renderer:
            frames.append(renderer.frame(scene.data).astype(int))
    spots = [
        view.project(s.data.xpos[s.robots["turtlebot0"].root_body_id], HEIGHT, WIDTH)[0]
        for s in scenes
    ]
    changed = np.argwhere(np.abs(frames[1] - frames[0]).sum(-1) > 30)[:, ::-1]  # (x, y)
    assert len(changed) > 20
    near = [np.linalg.norm(changed - spot, axis=1) for spot in spots]
    assert all(d.min() < 4 for d in near), "each position shows the robot at its projection"
    assert (np.minimum(*near) < 20).mean() > 0.95, "and nothing changed elsewhere"


def test_a_free_camera_needs_the_models_field_of_view(td_scene) -> None:
    scene = td_scene()
    view = overview_view(scene.model, scene.data, 4 / 3)
    wide = View(view.pos, view.axes, 60.0)
    with pytest.raises(ValueError, match="a free camera sees 45"):
        wide.free_camera(scene.model)
    with CameraRenderer(scene.model, 8, 8):  # the model is untouched by framing
        assert scene.model.vis.global_.fovy == 45.0
