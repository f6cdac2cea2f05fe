"""Build hook: put the top-level ``assets/`` tree into the wheel as ``maopg/assets/``.

All metadata lives in pyproject.toml. The MJCF files stay at the repository's top level (users
open and edit them there, and a symlink in git breaks on some platforms), yet an installed
package must carry them, so ``build_py`` copies them into the build's package. Editable installs
skip the copy: they keep reading the top-level folder (see ``maopg/sim/assets.py``).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ASSETS = Path(__file__).resolve().parent / "assets"
#: Where the copy goes, relative to the build's library folder.
PACKAGED = Path("maopg") / "assets"


class BuildPyWithAssets(build_py):
    """``build_py`` that also copies every file under ``assets/`` into ``maopg/assets/``."""

    def run(self) -> None:
        super().run()
        if not self.editable_mode:
            self._copy_assets()

    def _asset_files(self) -> list[Path]:
        if not ASSETS.is_dir():
            raise FileNotFoundError(
                f"{ASSETS} is missing: the wheel would ship without its MJCF files "
                "(an sdist must include assets/, see MANIFEST.in)"
            )
        return sorted(p.relative_to(ASSETS) for p in ASSETS.rglob("*") if p.is_file())

    def _copy_assets(self) -> None:
        target = Path(self.build_lib) / PACKAGED
        if target.exists():  # a reused build/ folder must not keep files deleted from assets/
            shutil.rmtree(target)
        for rel in self._asset_files():
            self.mkpath(str((target / rel).parent))
            self.copy_file(str(ASSETS / rel), str(target / rel))

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:  # type: ignore[override]
        outputs = super().get_outputs(include_bytecode)
        if not self.editable_mode:
            target = Path(self.build_lib) / PACKAGED
            outputs += [str(target / rel) for rel in self._asset_files()]
        return outputs


setup(cmdclass={"build_py": BuildPyWithAssets})
