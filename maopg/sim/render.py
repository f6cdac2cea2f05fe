"""Headless rendering: one reused ``mujoco.Renderer`` serves every camera of a scene.

Measured on CPU (llvmpipe, docs/DESIGN.md §2): shadows cost ~20x and 4x multisampling ~2x per
frame, so observation cameras render with both off; videos keep the nicer settings. Creating
one GL context per camera is slower than re-pointing a single renderer, and the output array
is preallocated so a batch of observations costs no allocation.

GL calls are serialised across threads (:data:`GL_LOCK`): Mesa's llvmpipe (22.3.6, Debian 12)
crashed with SIGSEGV in ``swrast_dri.so`` when two threads rendered at once, each into its own
context: now and then in training runs on the ``threads`` backend (Tool Delivery and Water
Filling RGB) and in a stress loop of ``ThreadVectorEnv`` steps, each time with both threads in
``mjr_render``. Physics and scene updates (``mj_step``, ``mjv_updateScene``) still overlap:
only context creation, the draw and the pixel read-back hold the lock.

Besides colour, a camera gives depth and segmentation (:mod:`maopg.sim.channels`). Colour and
depth come from one pass (the colour frame, then the depth buffer the same draw left behind);
segmentation needs a pass of its own, drawn with MuJoCo's segmentation colours (each geom an
id colour, no lighting, no sky), whose depth buffer serves where colour is off. Depth is read as
``mujoco.Renderer``'s depth mode reads it (:func:`metric_depth`) and clipped to the task's
range (:func:`depth_range`); ``bench/perf/camera_channels.py`` prints what each combination
costs.

A renderer still open when the interpreter exits (an error unwound past its owner's ``close``)
is closed by an exit hook that runs before MuJoCo's own, which terminates the EGL display:
freed later, each context would print two ``EGLError`` tracebacks under the real error.
"""

from __future__ import annotations

import atexit
import functools
import os
import threading
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco renders)
from maopg.sim.channels import RGB, ImageChannels
from maopg.sim.culling import cull_outside_view
from maopg.sim.egl_check import RenderError, gl_problem
from maopg.sim.segmentation import ClassTable

GL_LOCK = threading.RLock()
"""Held by every GL call of this module (see the module docstring for why)."""


def _fit_offscreen_buffer(model: mujoco.MjModel, height: int, width: int) -> None:
    """Grow the model's offscreen framebuffer to fit a frame of ``height`` x ``width``.

    MuJoCo sizes the framebuffer from ``<visual><global offwidth/offheight>`` when a renderer is
    created and refuses larger frames; the scene builder sets it from the sizes it is given,
    and this keeps a renderer asked for more (e.g. a bigger video) working instead of failing.
    """
    if height < 1 or width < 1:
        raise ValueError(f"render size must be positive, got {height}x{width}")
    glob = model.vis.global_
    glob.offwidth = max(int(glob.offwidth), width)
    glob.offheight = max(int(glob.offheight), height)


QUALITY = ("offsamples", "numslices", "numstacks", "numquads")
"""The ``<visual><quality>`` settings a GL context is made with."""


def make_renderer(
    model: mujoco.MjModel,
    height: int,
    width: int,
    *,
    shadows: bool,
    offsamples: int,
    detail: tuple[int, int, int] | None = None,
) -> mujoco.Renderer:
    """A ``mujoco.Renderer`` of ``height`` × ``width`` frames for ``model`` (its offscreen
    buffer enlarged to fit), with or without shadows and at ``offsamples`` multisamples (the
    costs are in docs/DESIGN.md §2), and MuJoCo's built-in meshes at ``detail`` (``numslices,
    numstacks, numquads``; default: the model's); a machine that cannot render is a one-line
    :class:`RenderError` before GL is touched."""
    _fit_offscreen_buffer(model, height, width)
    failed = f"cannot render {width}x{height} frames with MUJOCO_GL={os.environ.get('MUJOCO_GL')}"
    problem = gl_problem()  # before GL is touched: a GLFW without a display warns, then fails
    if problem is not None:
        raise RenderError(f"{failed}: {problem}")
    quality = model.vis.quality
    saved = [int(getattr(quality, key)) for key in QUALITY]
    # read once, when the GL context is made
    for key, value in zip(QUALITY, [offsamples, *(detail or saved[1:])], strict=True):
        setattr(quality, key, value)
    try:
        with GL_LOCK:
            renderer = mujoco.Renderer(model, height, width)
    except Exception as exc:  # MuJoCo and PyOpenGL raise several types, by backend
        raise RenderError(f"{failed}: {exc}") from exc
    finally:
        for key, value in zip(QUALITY, saved, strict=True):
            setattr(quality, key, value)
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = shadows
    return renderer


_OPEN: weakref.WeakSet[CameraRenderer] = weakref.WeakSet()
"""Every renderer not closed yet."""


def close_all() -> None:
    """Close every renderer still open (the exit hook; see the module docstring)."""
    for renderer in list(_OPEN):
        renderer.close()


@functools.cache
def _close_all_at_exit() -> None:
    """Register :func:`close_all` once, after the first GL context was made: exit hooks run
    last-registered first, so it runs before the EGL teardown MuJoCo registered then."""
    atexit.register(close_all)


def depth_range(model: mujoco.MjModel) -> tuple[float, float]:
    """``(near, far)`` in metres of a depth channel: ``near`` is MuJoCo's near clipping plane
    (``<visual><map znear>`` times the scene's extent: nothing nearer is drawn), ``far`` the
    scene's extent (``model.stat.extent``, the size MuJoCo gives the whole scene, more than
    any distance inside an arena). GL's own far plane lies 50 extents away by default, where
    the sky is drawn too: clipping at the extent keeps the range a CNN normalises by the
    room's size, and a pixel of sky reads ``far`` as one beyond the room does."""
    extent = float(model.stat.extent)
    return float(model.vis.map.znear) * extent, extent


def metric_depth(buffer: np.ndarray, model: mujoco.MjModel, orthographic: bool) -> np.ndarray:
    """Metres along the view axis (``float64``) of a depth buffer MuJoCo read in its
    reversed-Z form (``mjDEPTH_ZEROFAR``, what ``mujoco.Renderer`` sets): the same arithmetic
    as ``mujoco.Renderer``'s depth mode (its planes in ``float32`` as ``glFrustum`` has them,
    the division in ``float64``)."""
    extent = model.stat.extent
    znear = np.float32(model.vis.map.znear * extent)
    zfar = np.float32(model.vis.map.zfar * extent)
    z = buffer.astype(np.float64)
    if orthographic:
        return zfar - z * (zfar - znear)
    c_coef = -(zfar + znear) / (zfar - znear)
    d_coef = -(np.float32(2) * zfar * znear) / (zfar - znear)
    return (np.float32(-0.5) * d_coef) / (z + np.float32(-0.5) * c_coef - np.float32(0.5))


_SEGMENT_FLAGS = (mujoco.mjtRndFlag.mjRND_SEGMENT, mujoco.mjtRndFlag.mjRND_IDCOLOR)


class CameraRenderer:
    """Observations from named/indexed cameras: ``[N, H, W, planes]`` of ``channels``
    (:class:`~maopg.sim.channels.ImageChannels`; default colour only, uint8 ``[N, H, W, 3]``).

    ``fast=True`` (default) is the observation setting: no shadows, no reflections, no
    multisampling, and the geoms out of the camera's view are not drawn (the same pixels,
    :mod:`maopg.sim.culling`). ``fast=False`` keeps MuJoCo's defaults (shadows, offsamples from
    the model, 4 unless the MJCF says otherwise), for benchmarks and pretty pictures; it gives
    colour and depth only (multisampling blends segmentation colours at every edge).
    Segmentation needs the scene's ``classes`` (:func:`maopg.sim.segmentation.class_table`).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        height: int = 64,
        width: int = 64,
        *,
        fast: bool = True,
        detail: tuple[int, int, int] | None = None,
        channels: ImageChannels = RGB,
        classes: ClassTable | None = None,
    ) -> None:
        if "seg" in channels.names and (classes is None or not fast):
            raise ValueError("segmentation needs fast=True and the scene's class table")
        self.height, self.width = height, width
        self.channels = channels
        self._model = model
        self._classes = classes
        self._cull = fast  # a geom out of view may cast a shadow or a reflection into it
        offsamples = 0 if fast else int(model.vis.quality.offsamples)
        self._renderer = make_renderer(
            model, height, width, shadows=not fast, offsamples=offsamples, detail=detail
        )
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._colour = np.empty((height, width, 3), np.uint8)
        self._depth = np.empty((height, width), np.float32)
        _OPEN.add(self)
        _close_all_at_exit()

    def render(
        self,
        data: mujoco.MjData,
        cameras: Sequence[str | int | mujoco.MjvCamera],
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """Render each camera into ``out[i]`` (allocated when not given) and return ``out``."""
        shape = (len(cameras), self.height, self.width, self.channels.planes)
        dtype = np.dtype(self.channels.dtype)
        if out is None:
            out = np.empty(shape, dtype=dtype)
        elif out.shape != shape or out.dtype != dtype or not out.flags.c_contiguous:
            raise ValueError(f"out must be a C-contiguous {dtype} array of shape {shape}")
        renderer = self._renderer
        for i, camera in enumerate(cameras):
            renderer.update_scene(data, camera=camera)
            if self._cull:
                cull_outside_view(renderer.scene, self.width / self.height)
            with GL_LOCK:
                if self.channels.names == ("rgb",):
                    renderer.render(out=out[i])
                else:
                    self._render_channels(out[i])
        return out

    def _render_channels(self, frame: np.ndarray) -> None:
        """Fill ``frame`` (``[H, W, planes]``) with the channels: a colour pass when colour is
        on, a segmentation pass when seg is on or colour is off; depth is the depth buffer of
        the first of them (the module docstring). The GL lock is held."""
        names, channels, renderer = self.channels.names, self.channels, self._renderer
        depth = "depth" in names
        if "rgb" in names:
            renderer.render(out=self._colour)
            frame[..., channels.plane_slice("rgb")] = self._colour
            if depth:
                self._read_depth(frame[..., channels.plane_slice("depth")])
                depth = False
            if "seg" not in names:
                return
        flags = renderer.scene.flags
        saved = [bool(flags[flag]) for flag in _SEGMENT_FLAGS]
        for flag in _SEGMENT_FLAGS:
            flags[flag] = True
        try:
            renderer.render(out=self._colour)
            if depth:
                self._read_depth(frame[..., channels.plane_slice("depth")])
        finally:
            for flag, value in zip(_SEGMENT_FLAGS, saved, strict=True):
                flags[flag] = value
        if "seg" in names:
            assert self._classes is not None
            ids = self._colour.astype(np.int32)
            segment = ids[..., 0] | ids[..., 1] << 8 | ids[..., 2] << 16
            lookup = self._classes.lookup(renderer.scene)
            np.minimum(segment, len(lookup) - 1, out=segment)
            frame[..., channels.plane_slice("seg")] = lookup[segment][..., None]

    def _read_depth(self, plane: np.ndarray) -> None:
        """Read the depth buffer of the pass just drawn into ``plane`` (``[H, W, 1]``), in
        metres clipped to the channels' range. ``mujoco.Renderer`` reads depth only by drawing
        again; its GL context (``_mjr_context``) reads the buffer this draw left."""
        context = self._renderer._mjr_context  # mujoco's: no public reader
        mujoco.mjr_readPixels(None, self._depth, self._rect, context)
        near, far = self.channels.depth_range  # type: ignore[misc]  (depth is on)
        orthographic = bool(self._renderer.scene.camera[0].orthographic)
        metres = metric_depth(self._depth[::-1], self._model, orthographic)
        plane[..., 0] = np.clip(metres, near, far)

    def close(self) -> None:
        """Free the GL context now (at interpreter exit EGL teardown may already be gone)."""
        if self._renderer is not None:
            with GL_LOCK:
                self._renderer.close()
            self._renderer = None

    def __enter__(self) -> CameraRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(frozen=True)
class View:
    """Where a picture is taken from: the eye's world position, its axes as the columns of a
    3x3 matrix (right, up, backward: ``data.cam_xmat``'s convention, the view along ``-z``)
    and the vertical field of view in degrees (pixels are square)."""

    pos: np.ndarray
    axes: np.ndarray
    fovy: float

    @classmethod
    def of_camera(cls, model: mujoco.MjModel, data: mujoco.MjData, camera: str | int) -> View:
        """The current pose of a model's camera (``data`` current, as for a render)."""
        cam = camera if isinstance(camera, int) else model.camera(camera).id
        axes = data.cam_xmat[cam].reshape(3, 3).copy()
        return cls(data.cam_xpos[cam].copy(), axes, float(model.cam_fovy[cam]))

    def free_camera(self, model: mujoco.MjModel) -> mujoco.MjvCamera:
        """MuJoCo's free camera at this view: it looks from ``pos`` along ``-z`` with the
        model's ``<visual><global fovy>``, which must be this view's (a free camera has no
        field of view of its own), and without roll (``x`` level)."""
        if not np.isclose(self.fovy, float(model.vis.global_.fovy)):
            raise ValueError(
                f"a free camera sees {model.vis.global_.fovy} degrees, not {self.fovy}"
            )
        forward = -self.axes[:, 2]
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.azimuth = float(np.degrees(np.arctan2(forward[1], forward[0])))
        camera.elevation = float(np.degrees(np.arcsin(np.clip(forward[2], -1.0, 1.0))))
        camera.distance = 1.0
        camera.lookat[:] = self.pos + forward
        return camera

    def project(self, points: np.ndarray, height: int, width: int) -> np.ndarray:
        """Pixel coordinates ``[N, 2]`` (x right, y down, from the top-left corner) of world
        ``points [N, 3]`` in a ``height`` x ``width`` picture; a point behind the eye is NaN."""
        local = (np.asarray(points, dtype=np.float64).reshape(-1, 3) - self.pos) @ self.axes
        depth = -local[:, 2]
        focal = 0.5 * height / np.tan(np.radians(self.fovy) / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = 0.5 * width + focal * local[:, 0] / depth
            y = 0.5 * height - focal * local[:, 1] / depth
        pixels = np.stack([x, y], axis=1)
        pixels[depth <= 0] = np.nan
        return pixels


VIDEO_DETAIL = (14, 8, 1)
"""``numslices, numstacks, numquads`` of a fast video frame's spheres, cylinders and boxes:
half MuJoCo's slices and stacks, boxes' faces undivided, which looks the same at 640x480. On
llvmpipe a 640x480 overview then costs about two thirds of the CPU time it does with the
models' (28, 16, 4) (``bench/perf/video_speed.py``, second table: 22 ms for 31 on Water
Filling)."""


class VideoRenderer(CameraRenderer):
    """Larger frames of one camera, or of a :class:`View` (a video's framed overview).

    ``fast`` (default) renders as the observations do (no shadows, reflections nor
    multisampling, only the geoms in view) and with coarser built-in meshes
    (:data:`VIDEO_DETAIL`), which costs a fraction of MuJoCo's defaults at 640x480 on llvmpipe
    (``bench/perf/video_speed.py``); ``fast=False`` keeps the defaults.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        height: int = 480,
        width: int = 640,
        camera: str | int | View = "overview",
        *,
        fast: bool = True,
    ) -> None:
        super().__init__(model, height, width, fast=fast, detail=VIDEO_DETAIL if fast else None)
        self.camera = camera.free_camera(model) if isinstance(camera, View) else camera
        self._frame = np.empty((1, height, width, 3), dtype=np.uint8)

    def frame(self, data: mujoco.MjData) -> np.ndarray:
        """One ``[H, W, 3]`` frame (a fresh copy, safe to append to a video list)."""
        return self.render(data, [self.camera], out=self._frame)[0].copy()


def project_points(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: str | int,
    points: np.ndarray,
    height: int,
    width: int,
) -> np.ndarray:
    """Pixel coordinates ``[N, 2]`` (x right, y down, from the top-left corner) of world
    ``points [N, 3]`` in a ``height`` x ``width`` image of ``camera``; a point behind the camera
    is NaN.

    MuJoCo's camera conventions: ``data.cam_xmat`` holds the camera's axes in world coordinates
    as columns, the camera looks along its ``-z`` axis with ``+y`` up, and ``model.cam_fovy`` is
    the vertical field of view in degrees (pixels are square, so the horizontal focal length is
    the vertical one). ``data`` must be current (``mj_forward`` or a step since the last move),
    as for a render.
    """
    return View.of_camera(model, data, camera).project(points, height, width)
