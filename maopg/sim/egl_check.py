"""Check that headless EGL rendering works, and say exactly how to fix it when it does not.

Run by ``scripts/setup.sh``: ``python -m maopg.sim.egl_check``. Exits 1 with the ``apt-get``
line for the missing Debian/Ubuntu packages, so a fresh machine fails early and clearly instead
of deep inside the first render.

:func:`gl_problem` is the same diagnosis without a GL context — the ``MUJOCO_GL`` backend, its
library, a display for ``glfw`` — which a run that will render checks before it writes
anything, and :func:`exit_if_mujoco_cannot_import` the part of it that stops ``import mujoco``
itself, which the command lines check before they import anything that imports MuJoCo. Neither
imports MuJoCo; nor does :class:`RenderError`, what a renderer raises when GL fails it, so the
command lines know it as a user's error without loading MuJoCo.
"""

from __future__ import annotations

import ctypes.util
import functools
import importlib.util
import os
import sys

import maopg  # sets MUJOCO_GL=egl before mujoco is imported; shadowed_package reads it

APT_LINE = "sudo apt-get update && sudo apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri"


class RenderError(RuntimeError):
    """MuJoCo could not make a renderer: the machine's GL setup (``MUJOCO_GL``, its libraries,
    a display) or a frame size it cannot hold, not the code — a user error on a command line."""


GL_BACKENDS = ("egl", "osmesa", "glfw")
"""The ``MUJOCO_GL`` values maopg renders with (``egl`` headless, the default)."""


@functools.cache
def _found(library: str) -> bool:
    """Whether the shared library is installed (``find_library`` runs ``ldconfig``: cached)."""
    return ctypes.util.find_library(library) is not None


def _backend() -> str:
    return os.environ.get("MUJOCO_GL", "").lower().strip()


def shadowed_package() -> str | None:
    """Why ``maopg`` is not this package, or ``None``.

    A folder named ``maopg`` without ``__init__.py`` where Python looks first — a user's empty
    ``maopg/``, or the checkout itself seen from the folder above it — is imported as a
    namespace package in its place whenever the real one is found after the path's entries,
    as an editable install finds it: the modules below then load from the real package, but
    its ``__init__``, which sets ``MUJOCO_GL``, never runs. The rendering setup then looks
    broken (``MUJOCO_GL=None``), so :func:`import_problem`, where that failure is reported,
    names this cause first.
    """
    if getattr(maopg, "__file__", None) is not None:
        return None
    folders = ", ".join(str(folder) for folder in getattr(maopg, "__path__", ()))
    return (
        f"`maopg` here is the folder {folders} (a namespace package without __init__.py), "
        "not the installed package; rename the folder or run from elsewhere"
    )


def import_problem() -> str | None:
    """Why ``import mujoco`` would fail under this ``MUJOCO_GL`` (``maopg`` shadowed by a
    folder of that name: :func:`shadowed_package`; a value MuJoCo does not know, ``osmesa``
    without libOSMesa: PyOpenGL then fails inside MuJoCo's import, ``glfw`` without its Python
    package), or ``None``."""
    shadowed = shadowed_package()
    if shadowed is not None:
        return shadowed
    gl = _backend()
    if gl not in GL_BACKENDS:
        return f"MUJOCO_GL={gl!r}: maopg renders with MUJOCO_GL one of {list(GL_BACKENDS)}"
    if gl == "osmesa" and not _found("OSMesa"):
        return (
            "MUJOCO_GL=osmesa, but libOSMesa is not installed (sudo apt-get install "
            "libosmesa6); headless rendering works with MUJOCO_GL=egl"
        )
    if gl == "glfw" and importlib.util.find_spec("glfw") is None:
        return "MUJOCO_GL=glfw needs the glfw package (pip install glfw)"
    return None


def gl_problem() -> str | None:
    """Why MuJoCo cannot render offscreen under this ``MUJOCO_GL``, found without creating a
    context (:func:`import_problem`, libEGL missing, ``glfw`` without a display), or ``None``."""
    problem = import_problem()
    if problem is not None:
        return problem
    gl = _backend()
    if gl == "glfw" and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return (
            "MUJOCO_GL=glfw needs a display, and neither DISPLAY nor WAYLAND_DISPLAY is set; "
            "headless rendering works with MUJOCO_GL=egl"
        )
    if gl == "egl" and not _found("EGL"):
        return f"MUJOCO_GL=egl, but libEGL was not found; install it: {APT_LINE}"
    return None


def exit_if_mujoco_cannot_import(prog: str) -> None:
    """End the process with ``prog: error: ...`` and status 2 where ``import mujoco`` would fail
    (:func:`import_problem`): a command line's one line instead of PyOpenGL's traceback."""
    problem = import_problem()
    if problem is not None:
        print(f"{prog}: error: {problem}", file=sys.stderr)
        sys.exit(2)


def check() -> str:
    """Render one frame offscreen; return the GL renderer string or raise RuntimeError."""
    return gl_strings()[1]


def gl_strings() -> tuple[str, str]:
    """Render one frame offscreen; return the GL ``(vendor, renderer)`` or raise RuntimeError.

    The pair says where MuJoCo rendered: Mesa's software rasteriser (``llvmpipe``) on a machine
    without a GPU, the GPU's driver where EGL found one (on several GPUs,
    ``MUJOCO_EGL_DEVICE_ID`` picks which).
    """
    for lib in ("EGL", "GL"):
        if ctypes.util.find_library(lib) is None:
            raise RuntimeError(f"lib{lib} was not found on this system")
    import mujoco

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><light pos='0 0 2'/>"
        "<geom type='box' size='.1 .1 .1' rgba='1 0 0 1'/></worldbody></mujoco>"
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    try:
        with mujoco.Renderer(model, 16, 16) as renderer:
            renderer.update_scene(data)
            renderer.render()
            from OpenGL import GL

            names = [GL.glGetString(key) for key in (GL.GL_VENDOR, GL.GL_RENDERER)]
    except Exception as exc:  # mujoco raises several types depending on what is missing
        raise RuntimeError(f"EGL rendering failed: {exc!r}") from exc
    vendor, renderer = (n.decode() if isinstance(n, bytes) else str(n) for n in names)
    return vendor, renderer


def main() -> int:
    try:
        renderer = check()
    except RuntimeError as exc:
        print(f"[egl-check] FAILED: {exc}", file=sys.stderr)
        print(
            f"[egl-check] headless rendering needs EGL + Mesa. Install them with:\n    {APT_LINE}",
            file=sys.stderr,
        )
        return 1
    print(f"[egl-check] headless EGL rendering works (GL renderer: {renderer})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
