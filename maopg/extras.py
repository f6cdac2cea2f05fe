"""How to install one of maopg's optional extras (``ray``, ``wandb``), said the way that works
where this maopg runs from.

``pip install 'maopg[wandb]'`` fits an installed wheel. Run from a clone — an editable install
or the source on ``PYTHONPATH`` — pip would look for a package named maopg on its index instead
of the clone; there the clone's own extra is installed, ``pip install -e '.[wandb]'`` in its
root (or ``MAOPG_EXTRAS=wandb bash scripts/setup.sh``, which pins the versions).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
"""The folder that holds the ``maopg`` package: a clone's root, or ``site-packages``."""


def clone_root() -> Path | None:
    """The clone this maopg runs from — the folder whose ``pyproject.toml`` declares maopg,
    beside the package — or ``None`` for an installed wheel (``site-packages`` holds none)."""
    pyproject = ROOT / "pyproject.toml"
    if not pyproject.is_file():
        return None
    try:
        name = tomllib.loads(pyproject.read_text()).get("project", {}).get("name")
    except (OSError, tomllib.TOMLDecodeError):
        return None
    return ROOT if name == "maopg" else None


def install_hint(extra: str) -> str:
    """The command that installs ``extra`` for this maopg: from a clone, the clone's own extra
    (editable, run in the clone's root); from a wheel, ``maopg[extra]``."""
    root = clone_root()
    if root is None:
        return f"pip install 'maopg[{extra}]'"
    return f"pip install -e '.[{extra}]' (in {root}, the clone maopg runs from)"
