"""maopg: asynchronous, option-based multi-agent policy gradient on MuJoCo multi-robot tasks.

Importing the package selects headless EGL rendering *before* anything imports mujoco, because
MuJoCo picks its GL backend once, at import time. A user who wants another backend sets
``MUJOCO_GL`` themselves before importing maopg.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
# PyOpenGL must agree with MuJoCo on the platform, or its EGL calls fail at context creation.
if os.environ["MUJOCO_GL"] == "egl":
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

__version__ = "0.1.0"
