"""The setup's EGL check: passes here, names the exact fix when the libraries are missing, and
the cause when ``maopg`` is a folder of that name instead of the package."""

from __future__ import annotations

import ctypes.util
import os
import subprocess
import sys
from pathlib import Path

import maopg
from maopg.sim import egl_check


def test_headless_rendering_works_here(capsys) -> None:
    assert egl_check.main() == 0
    assert "GL renderer" in capsys.readouterr().out


def test_missing_egl_library_prints_the_apt_get_line(monkeypatch, capsys) -> None:
    real = ctypes.util.find_library
    monkeypatch.setattr(
        ctypes.util, "find_library", lambda name: None if name == "EGL" else real(name)
    )
    assert egl_check.main() == 1
    err = capsys.readouterr().err
    assert "libEGL was not found" in err
    assert "apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri" in err


EDITABLE = """
import os, sys
from importlib.machinery import PathFinder

PACKAGE = {package!r}


class Editable:
    \"\"\"Finds maopg after the path's entries, as an editable install's finder does.\"\"\"

    @classmethod
    def find_spec(cls, name, path=None, target=None):
        if name == "maopg":  # what the path's entries hold, the real package left out
            root = os.path.dirname(PACKAGE)
            entries = [p for p in sys.path if os.path.abspath(p or os.curdir) != root]
            return PathFinder.find_spec(name, entries)
        if name.startswith("maopg.") and name.count(".") == 1:
            return PathFinder.find_spec(name, [PACKAGE])
        return None


sys.meta_path.insert(0, Editable)
"""
"""The import machinery of a user whose maopg is an editable install (setuptools' finder, after
the path's): the only one under which a folder named ``maopg`` on the path shadows it."""


def test_a_folder_named_maopg_beside_a_script_is_named_as_the_cause(tmp_path) -> None:
    """A user's script next to an unrelated empty ``maopg/``: ``maopg`` is that folder, a
    namespace package, whose missing ``__init__`` leaves ``MUJOCO_GL`` unset. The command line
    and the renderer's check say so, not ``MUJOCO_GL=None``."""
    (tmp_path / "maopg").mkdir()
    script = tmp_path / "script.py"
    script.write_text(
        EDITABLE.format(package=str(Path(maopg.__file__).parent))
        + "from maopg.sim.egl_check import gl_problem\n"
        + "print(gl_problem())\n"
        + "from maopg.experiment.cli.train_cli import main\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    done = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    cause = (
        f"`maopg` here is the folder {tmp_path / 'maopg'} (a namespace package without "
        "__init__.py), not the installed package; rename the folder or run from elsewhere"
    )
    assert done.stdout == cause + "\n", done.stdout + done.stderr
    assert done.returncode == 2 and done.stderr == f"python -m train: error: {cause}\n"
