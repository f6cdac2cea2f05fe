"""Shared test setup: import maopg first so MUJOCO_GL=egl is set before any test imports mujoco."""

import maopg  # noqa: F401
