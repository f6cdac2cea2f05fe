"""View-frustum culling of a MuJoCo scene before an observation frame is drawn.

``mjr_render`` hands every geom of the scene to OpenGL, which drops what lies outside the
view only after it has transformed and lit all of its vertices. On a software renderer
(Mesa's llvmpipe, what a headless CPU machine has) that per-vertex work is most of a small
frame's cost, and a robot's camera sees few of the scene's geoms: of Water Filling's 66 about
47 are out of a robot camera's view (``bench/perf/culling.py`` prints both tasks'). A geom whose
bounding sphere lies wholly outside the view frustum cannot colour a pixel, so it is retyped
``mjGEOM_NONE``, which ``mjr_render`` skips;
``mjv_updateScene`` rewrites every geom before the next frame, so nothing has to be restored.

Only frames without shadows and reflections may be culled: a geom out of view can still cast
a shadow into it or be mirrored by a reflective floor. The lights, fog, haze and skybox do
not depend on the other geoms. The frames are the same to the last bit
(``tests/sim/test_culling.py`` renders both ways over Tool Delivery's and Water Filling's
episodes); ``bench/perf/culling.py`` measures the time saved.
"""

from __future__ import annotations

import mujoco
import numpy as np

_SKIPPED = int(mujoco.mjtGeom.mjGEOM_NONE)

SAFETY = 1.01
"""Bounding spheres are inflated by 1% (plus 1 mm) before the test, so that a geom that
touches the frustum within float32 rounding of the GL pipeline is drawn."""


def cull_outside_view(scene: mujoco.MjvScene, aspect: float) -> int:
    """Retype the geoms of ``scene`` that lie outside its camera's view as ``mjGEOM_NONE``;
    returns how many. ``aspect`` is the frame's width over its height.

    The frustum is the one ``mjr_render`` draws with: the average of the scene's two GL
    cameras (they differ only in stereo, which is left alone), with square pixels, so its half
    width at the near plane is ``aspect`` times its half height. Stereo, orthographic cameras
    and cameras given by their intrinsics (a frustum width of their own) are drawn whole. A
    geom is culled when its bounding sphere (``geom_rbound`` about the geom's centre; zero,
    i.e. unknown or unbounded, for planes, height fields and decorations, which are always
    drawn) lies wholly behind the near plane or beyond one of the four side planes. The far
    plane is not tested.
    """
    if scene.stereo != mujoco.mjtStereo.mjSTEREO_NONE or scene.ngeom == 0:
        return 0
    camera = mujoco.mjv_averageCamera(scene.camera[0], scene.camera[1])
    if camera.orthographic or camera.frustum_width:  # an intrinsics camera: drawn whole
        return 0
    geoms = scene.geoms[: scene.ngeom]
    radius = np.fromiter((g.modelrbound for g in geoms), dtype=np.float64, count=len(geoms))
    bounded = np.flatnonzero(radius > 0)
    if bounded.size == 0:
        return 0
    forward, up = np.asarray(camera.forward, np.float64), np.asarray(camera.up, np.float64)
    axes = np.stack([np.cross(forward, up), up, forward], axis=1)  # columns: x right, y up, z in
    centres = np.array([geoms[i].pos for i in bounded], dtype=np.float64)
    x, y, z = ((centres - np.asarray(camera.pos, np.float64)) @ axes).T
    r = radius[bounded] * SAFETY + 1e-3
    near = camera.frustum_near
    half_width = 0.5 * aspect * (camera.frustum_top - camera.frustum_bottom)
    outside = z < near - r
    # Each side plane passes through the eye and one edge of the near rectangle, at offset
    # ``edge`` along its axis; ``sign`` points out of the view. A point (coord, z) is that far
    # beyond the plane: sign * (coord * near - edge * z) / hypot(near, edge).
    for coord, edge, sign in (
        (x, camera.frustum_center + half_width, 1.0),
        (x, camera.frustum_center - half_width, -1.0),
        (y, camera.frustum_top, 1.0),
        (y, camera.frustum_bottom, -1.0),
    ):
        outside |= sign * (coord * near - edge * z) > r * np.hypot(near, edge)
    for i in bounded[outside]:
        geoms[i].type = _SKIPPED
    return int(outside.sum())
