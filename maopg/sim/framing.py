"""Where a video's overview looks from: the scene's extent, fitted into the picture.

An arena's ``overview`` camera is placed by hand for a room, so a robot of 40 cm in Water
Filling's 10 m room is a speck, and the walls and the sky around the room take much of the
picture. :func:`fit_view` keeps the camera's direction (the arena's author chose the angle)
and its field of view, and moves it as close as the scene allows: every point of
:func:`scene_extent` inside the picture, the extent centred, a small margin left.

The extent is where things are and go: the boxes of every body but the world (robots, props,
boxes, jars, the human) and the finite floor planes, which bound where robots drive. The world
body's other geoms (walls, fixed furniture) are left out: a room's walls stand on the floor's
edges, and their height would only push the camera back. It is taken once, at the state the
video starts in; the floor keeps what moves later in the picture.
"""

from __future__ import annotations

import mujoco
import numpy as np

from maopg.sim.render import View

MARGIN = 0.03
"""Fraction of the picture's half width and half height left free around the extent."""


def scene_extent(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The corners ``[8 * k, 3]`` of the world-aligned bounding boxes of the scene's finite
    floor planes and of each body's geoms (bodies other than the world), at ``data``'s state
    (current, as for a render)."""
    plane = int(mujoco.mjtGeom.mjGEOM_PLANE)
    boxes = []
    for g in range(model.ngeom):
        rotation = data.geom_xmat[g].reshape(3, 3)
        if model.geom_type[g] == plane:
            half = np.array([model.geom_size[g, 0], model.geom_size[g, 1], 0.0])
            if half[0] <= 0 or half[1] <= 0:
                continue  # an infinite plane bounds nothing
            centre = data.geom_xpos[g]
        elif model.geom_bodyid[g] == 0:
            continue  # walls and fixed furniture
        else:
            centre = data.geom_xpos[g] + rotation @ model.geom_aabb[g, :3]
            half = model.geom_aabb[g, 3:]
        reach = np.abs(rotation) @ half
        boxes.append((centre - reach, centre + reach))
    if not boxes:
        raise ValueError("the scene has no body and no finite floor to frame")
    corners = []
    for lo, hi in boxes:
        for k in range(8):
            corners.append([hi[i] if k >> i & 1 else lo[i] for i in range(3)])
    return np.array(corners, dtype=np.float64)


def fit_view(points: np.ndarray, axes: np.ndarray, fovy: float, aspect: float) -> View:
    """The :class:`View` along ``axes`` (columns right, up, backward) with vertical field of
    view ``fovy`` (degrees) and pictures ``aspect`` (width over height) wide that is closest to
    ``points`` while they all lie in the picture, :data:`MARGIN` inside its edges.

    In the eye's coordinates a point at ``(x, y)`` and depth ``z`` is in the picture when
    ``|x| <= tx * z`` and ``|y| <= ty * z`` (``ty = tan(fovy / 2)``, ``tx = aspect * ty``).
    Along the right axis this bounds the eye's position ``(er, ef)`` (along right and forward)
    by ``er - tx * ef >= max(a - tx * c)`` and ``er + tx * ef <= min(a + tx * c)`` over the
    points (``a``, ``c``: their coordinates along right and forward), so ``ef`` is at most half
    the gap over ``tx``, with ``er`` in the middle; likewise along up. The eye takes the
    largest ``ef`` both allow: the binding direction fills the picture, the other is centred.
    """
    right, up, forward = axes[:, 0], axes[:, 1], -axes[:, 2]
    ty = np.tan(np.radians(fovy) / 2) * (1.0 - MARGIN)
    tx = aspect * ty
    depth = points @ forward
    place, reach = [], []
    for axis, tan in ((right, tx), (up, ty)):
        across = points @ axis
        low, high = np.max(across - tan * depth), np.min(across + tan * depth)
        place.append((low + high) / 2)
        reach.append((high - low) / (2 * tan))
    eye = place[0] * right + place[1] * up + min(reach) * forward
    return View(eye, np.array(axes, dtype=np.float64), float(fovy))


def level_axes(forward: np.ndarray) -> np.ndarray:
    """The axes (columns right, up, backward) of an eye looking along ``forward`` without
    roll: its right axis level, as MuJoCo's free camera has it."""
    forward = np.asarray(forward, dtype=np.float64) / np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    return np.stack([right, np.cross(right, forward), -forward], axis=1)


DEFAULT_FORWARD = (0.0, np.cos(np.radians(60.0)), -np.sin(np.radians(60.0)))
"""Looking north, 60 degrees down (the arenas' overview cameras look about so)."""


def overview_view(
    model: mujoco.MjModel, data: mujoco.MjData, aspect: float, camera: str = "overview"
) -> View:
    """The framed overview of a scene at ``data``'s state: the direction of its ``camera``
    (:data:`DEFAULT_FORWARD` where the model has none), level, and the field of view of the
    model's free camera (``<visual><global fovy>``, what :meth:`View.free_camera` renders
    with), fitted to :func:`scene_extent`."""
    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
    forward = -data.cam_xmat[cam].reshape(3, 3)[:, 2] if cam >= 0 else DEFAULT_FORWARD
    axes = level_axes(np.asarray(forward))
    return fit_view(scene_extent(model, data), axes, float(model.vis.global_.fovy), aspect)
