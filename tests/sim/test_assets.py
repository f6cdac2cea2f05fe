"""Every MJCF file under assets/ loads on its own (a user can open any of them in MuJoCo)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from maopg.sim.robots import ASSETS_DIR

FILES = sorted(ASSETS_DIR.rglob("*.xml"))


def test_assets_are_found() -> None:
    kinds = {f.parent.name for f in FILES}
    assert {"robots", "props", "arenas"} <= kinds


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ASSETS_DIR)))
def test_asset_loads_alone(path: Path) -> None:
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    assert model.nbody >= 2  # the world and at least one body of its own
