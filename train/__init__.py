"""``python -m train``: train a method on a task (see :mod:`train.__main__` for the CLI)."""

import maopg  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)
