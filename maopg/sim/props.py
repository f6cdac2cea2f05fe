"""Runtime handles for props whose looks follow task state, and arena layout look-ups (sites,
the floor's extent).

A jar's water level is shown by rewriting its liquid geom's half-height and centre in the
compiled model (``geom_size``/``geom_pos`` are mutable), so every camera sees the level without
recompiling. The liquid is a visual-only geom, so this never changes the physics.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

#: Half-height (m) of the liquid at level 0: a film, so the geom never has a zero size.
_MIN_HALF_HEIGHT = 1e-3


class JarHandle:
    """Water level of one attached ``assets/props/jar.xml`` (prefix ``"<prefix>/"``).

    The MJCF's liquid geometry is the full jar (level 1.0); the bottom stays put and the top
    moves with the level. Pass ``data`` to also refresh the geom's world position at once, so a
    render made before the next physics step already shows the new level.
    """

    def __init__(self, model: mujoco.MjModel, prefix: str, data: mujoco.MjData | None = None):
        name = f"{prefix}/liquid"
        self._geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if self._geom < 0:
            raise KeyError(f"the model has no jar liquid geom '{name}'")
        self.model = model
        self.data = data
        self._full_half = float(model.geom_size[self._geom, 1])
        self._bottom = float(model.geom_pos[self._geom, 2]) - self._full_half
        self._body = int(model.geom_bodyid[self._geom])
        self._level = 1.0

    @property
    def level(self) -> float:
        return self._level

    @property
    def geom_id(self) -> int:
        return self._geom

    def set_level(self, level: float) -> None:
        """Show water level ``level`` (clipped to [0, 1]) in every following render."""
        self._level = min(1.0, max(0.0, float(level)))
        half = max(_MIN_HALF_HEIGHT, self._level * self._full_half)
        g = self._geom
        self.model.geom_size[g, 1] = half
        self.model.geom_pos[g, 2] = self._bottom + half
        if self.data is not None:
            b = self._body
            rot = self.data.xmat[b].reshape(3, 3)
            self.data.geom_xpos[g] = self.data.xpos[b] + rot @ self.model.geom_pos[g]


def layout_sites(arena: str | Path | mujoco.MjModel, prefix: str = "") -> dict[str, np.ndarray]:
    """World positions of an arena's sites whose names start with ``prefix`` (e.g. ``jar_``).

    Arenas mark jar stands and spawn points with sites, so tasks read the layout from the MJCF
    instead of repeating coordinates. ``arena`` is the file, or an arena compiled already (a
    room generated in code).
    """
    model = arena if isinstance(arena, mujoco.MjModel) else mujoco.MjModel.from_xml_path(str(arena))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return {
        model.site(i).name: data.site_xpos[i].copy()
        for i in range(model.nsite)
        if model.site(i).name.startswith(prefix)
    }


@dataclass(frozen=True)
class Floor:
    """The rectangle an arena's ``floor`` plane covers (m): where a robot may stand."""

    low: tuple[float, float]
    high: tuple[float, float]

    @property
    def half_extent(self) -> tuple[float, float]:
        return ((self.high[0] - self.low[0]) / 2, (self.high[1] - self.low[1]) / 2)

    def require_inside(self, setting: str, xy: Sequence[float]) -> None:
        """``ValueError`` naming ``setting`` unless the planar point ``xy`` lies on the floor:
        a task checks the positions its config sets before it compiles its scene."""
        if not all(lo <= v <= hi for v, lo, hi in zip(xy, self.low, self.high, strict=True)):
            raise ValueError(
                f"{setting}={tuple(xy)} lies outside the arena: x must be in "
                f"[{self.low[0]:g}, {self.high[0]:g}] and y in [{self.low[1]:g}, {self.high[1]:g}]"
            )


def arena_floor(arena: str | Path | mujoco.MjModel) -> Floor:
    """The :class:`Floor` of an arena MJCF or compiled model (its geom named ``floor``, a plane
    or a box)."""
    model = arena if isinstance(arena, mujoco.MjModel) else mujoco.MjModel.from_xml_path(str(arena))
    floor = model.geom("floor")
    centre, half = floor.pos[:2], floor.size[:2]
    low, high = centre - half, centre + half
    return Floor((float(low[0]), float(low[1])), (float(high[0]), float(high[1])))
