"""Check that headless EGL rendering works, and say exactly how to fix it when it does not.

Run by ``scripts/setup.sh``: ``python -m maopg.sim.egl_check``. Exits 1 with the ``apt-get``
line for the missing Debian/Ubuntu packages, so a fresh machine fails early and clearly instead
of deep inside the first render.
"""

from __future__ import annotations

import ctypes.util
import sys

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)

APT_LINE = "sudo apt-get update && sudo apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri"


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
