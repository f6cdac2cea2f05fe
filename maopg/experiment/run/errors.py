"""What a user's input can cause, and how it ends a command: one line naming it, status 2.

A mistake of the user's (a bad setting, a missing run directory, a plugin that fails to import)
is reported as one line; ``--debug`` shows the traceback instead. A training run that went
non-finite (NaN or infinity in a loss, gradient or weight) ends the same way: its settings, not
the code, are at fault. So does a machine that cannot render what the command needs
(``MUJOCO_GL`` and its libraries, a display for ``glfw``): its setup, not the code. Shared by the
command lines and the reproduction grid's cell processes.
"""

from __future__ import annotations

import sys
from collections.abc import Callable

from maopg.learner.errors import CheckpointError, NonFiniteError
from maopg.plugins import PluginError
from maopg.sim.egl_check import RenderError

USER_ERRORS = (
    ValueError,
    KeyError,
    FileNotFoundError,
    FileExistsError,
    NotADirectoryError,
    IsADirectoryError,
    PermissionError,
    CheckpointError,
    NonFiniteError,
    PluginError,
    RenderError,
)
"""What a user's input can cause (the path errors: a file or directory the user named); anything
else is a bug and keeps its traceback."""


def reporting_user_errors(prog: str, action: Callable[[], int], *, debug: bool = False) -> int:
    """``action()``'s exit status; a user error prints ``prog: error: ...`` and returns 2
    (re-raised instead with ``debug``)."""
    try:
        return action()
    except USER_ERRORS as err:
        if debug:
            raise
        message = err.args[0] if isinstance(err, KeyError) and err.args else err
        print(f"{prog}: error: {message}", file=sys.stderr)
        return 2
