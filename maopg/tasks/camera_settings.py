"""Camera settings given for every robot or per robot role, read from one setting's value.

The settings layer has no mappings (a setting is a number, a string or a fixed tuple), and a
task's robots play roles (``ground``, ``drone``, ``arm``: :data:`maopg.sim.robots.ROLES`) that
may want different cameras: a drone's wide lens, a ground robot's camera tilted down. So a
camera setting takes either a value for every robot (``env.camera_fovy=90``,
``env.camera_offset=[0, 0.1, 0]``) or a comma-separated list of ``role:value`` entries, where
one entry without a role sets the roles not named (``env.camera_fovy=ground:70,drone:110``,
``env.camera_fovy=60,drone:110``); the numbers of a vector value are separated by spaces
(``env.camera_offset=drone:0 0 -0.05``). A role the task's robots do not play, a number that is
not one or a vector of the wrong length is refused in one line naming the setting and what is
allowed, when the config is made.

Plain Python: the command line's ``--help`` lists these settings without importing numpy or
MuJoCo.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

Value = float | tuple[float, ...]
"""One robot's value of a camera setting: a number, or a vector of numbers."""

EVERY = None
"""The key of the value set for every role not named (an entry without a role)."""


def role_values(
    setting: str, value: Any, size: int, roles: Sequence[str]
) -> dict[str | None, Value]:
    """``{role: value}`` (the key :data:`EVERY` for the entry without a role) of a camera
    setting's ``value`` (``None``: nothing set), whose values are ``size`` numbers each (one:
    a plain number) and whose roles must be among ``roles``."""
    if value is None:
        return {}
    if not isinstance(value, str):
        return {EVERY: value}
    form = "a number" if size == 1 else f"{size} numbers separated by spaces"
    allowed = (
        f"{form} for every robot, or 'role:value' entries separated by commas "
        f"(roles: {', '.join(roles)}; one entry without a role sets the others)"
    )
    values: dict[str | None, Value] = {}
    for entry in value.split(","):
        role, sep, text = entry.strip().rpartition(":")
        key = role.strip() if sep else EVERY
        if key is not EVERY and key not in roles:
            raise ValueError(
                f"{setting}: the task's robots play no role {key!r}; roles: {', '.join(roles)}"
            )
        if key in values:
            which = f"role {key!r}" if key else "a value without a role"
            raise ValueError(f"{setting}={value!r} gives {which} twice; allowed: {allowed}")
        try:
            numbers = tuple(float(word) for word in text.split())
        except ValueError:
            numbers = ()
        if len(numbers) != size or not all(math.isfinite(x) for x in numbers):
            raise ValueError(f"{setting}: {entry.strip()!r} is not {form}; allowed: {allowed}")
        values[key] = numbers[0] if size == 1 else numbers
    return values


def value_for(values: dict[str | None, Value], role: str) -> Value | None:
    """The value a robot of ``role`` gets from :func:`role_values`' result (``None``: none
    set, the robot keeps its own)."""
    return values.get(role, values.get(EVERY))


@dataclass(frozen=True)
class CameraMount:
    """What a task's camera settings give one robot's camera (:mod:`maopg.sim.mounts`)."""

    fovy: float | None = None
    """Degrees; ``None``: the robot's own."""
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @property
    def as_compiled(self) -> bool:
        """Whether the camera stays as the robot's file mounts it."""
        return self.fovy is None and not any(self.offset) and not any(self.rotation)
