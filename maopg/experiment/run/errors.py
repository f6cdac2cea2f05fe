"""What a user's input can cause, and how it ends a command: one line naming it, status 2.

A mistake of the user's (a bad setting, a missing run directory, a plugin that fails to import)
is reported as one line; ``--debug`` shows the traceback instead. A training run that went
non-finite (NaN or infinity in a loss, gradient or weight) ends the same way: its settings, not
the code, are at fault. So does a machine that cannot render what the command needs
(``MUJOCO_GL`` and its libraries, a display for ``glfw``): its setup, not the code. So does a
write the machine refuses — a full disk, a read-only file system (:data:`REFUSED_WRITES`) —
as ``cannot write PATH: CAUSE``: the writers name the file (a checkpoint's says that the one
before it is intact, :mod:`maopg.learner.checkpoint`). Shared by the command lines and the
reproduction grid's cell processes.
"""

from __future__ import annotations

import errno
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

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
REFUSED_WRITES = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS})
"""The ``errno`` of an ``OSError`` by which the machine refuses a write: no space left, the
disk quota exhausted, a read-only file system."""


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
    except OSError as err:
        if debug or err.errno not in REFUSED_WRITES:
            raise
        where = f"cannot write {err.filename}" if err.filename else "a write failed"
        print(f"{prog}: error: {where}: {err.strerror}", file=sys.stderr)
        return 2


@contextmanager
def writing_into(directory: Path) -> Iterator[None]:
    """Around writing the files of ``directory``: a refused write (:data:`REFUSED_WRITES`) that
    names no file — one into a file already open, whose name Python does not keep — names
    ``directory``."""
    try:
        yield
    except OSError as err:
        if err.errno in REFUSED_WRITES and err.filename is None:
            raise type(err)(err.errno, err.strerror, str(directory)) from err
        raise
