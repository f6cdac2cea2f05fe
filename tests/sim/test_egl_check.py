"""The setup's EGL check: passes here, and names the exact fix when the libraries are missing."""

from __future__ import annotations

import ctypes.util

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
