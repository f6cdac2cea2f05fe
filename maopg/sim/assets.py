"""Where the MJCF assets (robots, props, arenas) live, resolved once at import.

The source tree keeps ``assets/`` at the repository's top level, next to ``maopg/``; a wheel
carries a copy inside the package as ``maopg/assets/`` (``setup.py`` copies it at build time),
because an installed package has no repository around it. The package copy wins when present,
so an installed maopg never reads a stray checkout; an editable install or a plain clone has no
package copy and uses the top-level folder, so edits to the MJCF files take effect at once.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parents[1]
#: The copy a wheel installs inside the package (absent in a source tree).
PACKAGE_ASSETS = _PACKAGE_DIR / "assets"
#: The repository's top-level folder (absent in an installed wheel).
REPO_ASSETS = _PACKAGE_DIR.parent / "assets"


def find_assets_dir() -> Path:
    """Return the assets folder: the installed package copy, else the repository's one."""
    for candidate in (PACKAGE_ASSETS, REPO_ASSETS):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        "maopg's MJCF assets were not found: looked for the installed package copy "
        f"{PACKAGE_ASSETS} and the repository's {REPO_ASSETS}. Reinstall maopg from a wheel "
        "or sdist, or run from a clone that has assets/ at its top level."
    )


#: The folder holding ``robots/``, ``props/`` and ``arenas/``.
ASSETS_DIR = find_assets_dir()

__all__ = ["ASSETS_DIR", "PACKAGE_ASSETS", "REPO_ASSETS", "find_assets_dir"]
