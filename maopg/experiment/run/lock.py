"""One writer per run directory.

``train`` holds an exclusive lock on its run directory for as long as it runs, so a second
``train`` that names the same directory stops with one line instead of interleaving two runs'
rows and checkpoints, or deleting a live run with ``--overwrite``; ``reproduce`` takes the lock
of a cell before it launches the cell's training, so several ``reproduce`` invocations over one
grid share out its cells (each skips the cells another holds) instead of colliding.

Why ``flock`` on the directory itself: it writes nothing (a failed start leaves nothing behind),
the kernel drops it when its holder exits however it dies (no stale lock after a kill), and
``--overwrite`` empties the directory rather than replacing it, so the lock stays on the one
directory. A parent that took a cell's lock hands it to the training subprocess as an inherited
descriptor named by :data:`INHERITED`, which the child adopts, so the cell is never unlocked
between the two. The lock is one machine's: a network file system does not share a directory's
``flock`` between machines, so invocations on several machines must not share a run root. Where
the platform or the file system has no ``flock`` (Windows) runs go unlocked, as they did before.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from types import TracebackType

try:
    import fcntl
except ImportError:  # Windows: no flock
    fcntl = None  # type: ignore[assignment]

TRIES, RETRY_S = 5, 0.05
"""A held lock is tried again for a moment before it counts as busy: :func:`held_elsewhere`
takes and drops it to look, and must not turn a start that meets it into a refusal."""
INHERITED = "MAOPG_RUN_DIR_LOCK"
"""Environment variable: ``<descriptor>:<run directory>`` of a lock a parent process took for
this process (``reproduce`` launching a cell)."""


class RunDirBusy(ValueError):
    """Another process holds the run directory (a user error: one line, exit status 2)."""


class RunDirLock:
    """The exclusive lock of one run directory; a context manager that takes it on entry where
    the directory exists (:meth:`acquire` again once it has been created) and releases it on
    exit. Raises :class:`RunDirBusy` where another process holds it."""

    def __init__(self, run_dir: Path) -> None:
        self.run_dir = Path(run_dir)
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    @property
    def descriptor(self) -> int | None:
        """The locked descriptor, to hand to a child process (:func:`child_environment`)."""
        return self._fd

    def acquire(self) -> bool:
        """Take the lock if the directory exists; ``False`` where it does not, or where the
        file system cannot lock (then the run goes unlocked)."""
        if self._fd is not None:
            return True
        if fcntl is None or not self.run_dir.is_dir():
            return False
        fd = self._adopt()
        if fd is None:
            opened = os.open(self.run_dir, os.O_RDONLY)
            # Above the standard streams: a descriptor 0-2 handed to a child would be its stdin.
            fd = fcntl.fcntl(opened, fcntl.F_DUPFD_CLOEXEC, 3)
            os.close(opened)
        for attempt in range(TRIES):
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if attempt == TRIES - 1:
                    os.close(fd)
                    raise RunDirBusy(
                        f"run directory {self.run_dir} is in use: another process is training "
                        "in it; wait for it to end, or choose another --run-dir"
                    ) from None
                time.sleep(RETRY_S)  # perhaps only a probe (held_elsewhere) holding it briefly
            except OSError:  # this file system has no flock
                os.close(fd)
                return False
        self._fd = fd
        return True

    def _adopt(self) -> int | None:
        """The descriptor a parent locked for this directory and handed down, if any (taken
        out of the environment, so that it is adopted once)."""
        handed = os.environ.get(INHERITED, "")
        fd, _, path = handed.partition(":")
        if not fd.isdigit() or Path(path) != self.run_dir.resolve():
            return None
        del os.environ[INHERITED]
        try:
            same = os.path.samestat(os.fstat(int(fd)), os.stat(self.run_dir))
        except OSError:
            return None
        if not same:
            return None
        os.set_inheritable(int(fd), False)  # this process's own children must not keep it
        return int(fd)

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the last descriptor of the lock drops it
            self._fd = None

    def __enter__(self) -> RunDirLock:
        self.acquire()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.release()


def child_environment(lock: RunDirLock) -> tuple[dict[str, str], tuple[int, ...]]:
    """The environment and the descriptors to pass to a subprocess that is to train in the
    directory ``lock`` holds (``subprocess.run(..., env=env, pass_fds=fds)``)."""
    env = dict(os.environ)
    if lock.descriptor is None:
        return env, ()
    env[INHERITED] = f"{lock.descriptor}:{lock.run_dir.resolve()}"
    return env, (lock.descriptor,)


def held_elsewhere(run_dir: Path) -> bool:
    """Whether another holder has the lock of ``run_dir`` now (one try: a look, not a wait)."""
    if fcntl is None or not Path(run_dir).is_dir():
        return False
    fd = os.open(run_dir, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:  # no flock here: nothing can hold it
        return False
    finally:
        os.close(fd)
    return False
