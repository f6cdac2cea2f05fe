"""Robot registry: a name maps to an MJCF file, an adapter class and its constants.

Built-ins are registered with lazy ``"module:Attr"`` strings, so importing the registry imports
no robot module (they can be written, and fail, independently) and a task config can name a
robot without importing it. ``register_robot`` adds user robots from their own files::

    register_robot("mybot", "path/to/mybot.xml", "mypkg.mybot:MyBotAdapter", MyBotConstants())
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from maopg.sim.assets import ASSETS_DIR  # robots, props, arenas (see maopg/sim/assets.py)
from maopg.sim.robots.base import (
    ArmAdapter,
    DroneAdapter,
    GroundAdapter,
    PlanarBaseConstants,
    PlanarGroundAdapter,
    RobotAdapter,
)

__all__ = [
    "ASSETS_DIR",
    "ROLES",
    "ArmAdapter",
    "DroneAdapter",
    "GroundAdapter",
    "PlanarBaseConstants",
    "PlanarGroundAdapter",
    "RobotAdapter",
    "RobotSpec",
    "get_robot",
    "register_robot",
    "require_role",
    "robot_names",
    "robots_of_role",
    "role_of",
]

ROLES: dict[str, type[RobotAdapter]] = {
    "ground": GroundAdapter,
    "drone": DroneAdapter,
    "arm": ArmAdapter,
}
"""Each role a task gives a robot, and the adapter class a robot in it must have."""


def _resolve(ref: Any) -> Any:
    """Import ``"package.module:Attr"`` lazily; any other value is returned as is."""
    if not isinstance(ref, str):
        return ref
    module, sep, attr = ref.partition(":")
    if not sep:
        raise ValueError(f"expected 'package.module:Attr', got {ref!r}")
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class RobotSpec:
    """Everything needed to put one robot type in a scene."""

    name: str
    mjcf: Path
    #: An adapter class, or ``"module:Class"`` imported on first use.
    adapter: type[RobotAdapter] | str
    #: A constants instance, a constants class (instantiated with defaults), ``"module:Attr"``
    #: naming either, or None (the adapter's own default ``Constants()``).
    constants: Any = None

    def adapter_class(self) -> type[RobotAdapter]:
        cls = _resolve(self.adapter)
        if not (isinstance(cls, type) and issubclass(cls, RobotAdapter)):
            raise TypeError(f"robot '{self.name}': {self.adapter!r} is not a RobotAdapter class")
        return cls

    def resolve_constants(self) -> Any:
        """The constants instance the robot is built with (None: the adapter's ``Constants()``)."""
        value = _resolve(self.constants)
        if value is None:
            value = self.adapter_class().Constants
        return value() if isinstance(value, type) else value


_REGISTRY: dict[str, RobotSpec] = {}


def register_robot(
    name: str,
    mjcf: str | Path,
    adapter: type[RobotAdapter] | str,
    constants: Any = None,
    *,
    overwrite: bool = False,
) -> RobotSpec:
    """Register a robot type; relative MJCF paths are taken relative to ``assets/``."""
    if name in _REGISTRY and not overwrite:
        raise ValueError(f"robot '{name}' is already registered (pass overwrite=True to replace)")
    path = Path(mjcf)
    if not path.is_absolute():
        path = path if path.exists() else ASSETS_DIR / path
    spec = RobotSpec(name=name, mjcf=path.resolve(), adapter=adapter, constants=constants)
    _REGISTRY[name] = spec
    return spec


def get_robot(name: str) -> RobotSpec:
    """The spec of a registered robot; an unknown name fails with the list of known ones."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise KeyError(
            f"unknown robot '{name}'; known robots: {', '.join(robot_names())}"
        ) from None


def robot_names() -> list[str]:
    return sorted(_REGISTRY)


for _name, _cls, _consts in (
    ("turtlebot", "TurtlebotAdapter", "TurtlebotConstants"),
    ("fetch", "FetchAdapter", "FetchConstants"),
    ("vehicle", "VehicleAdapter", "VehicleConstants"),
    ("drone", "DroneAdapter", "DroneConstants"),
    ("diffbot", "DiffbotAdapter", "DiffbotConstants"),
):
    _module = f"maopg.sim.robots.{_name}"
    register_robot(
        _name, ASSETS_DIR / "robots" / f"{_name}.xml", f"{_module}:{_cls}", f"{_module}:{_consts}"
    )


def role_of(adapter: type[RobotAdapter]) -> str:
    """The role an adapter class plays (the first of :data:`ROLES` it subclasses)."""
    for role, base in ROLES.items():
        if issubclass(adapter, base):
            return role
    bases = ", ".join(b.__name__ for b in ROLES.values())
    raise ValueError(f"{adapter.__name__} is none of {bases}: it has no role to check")


def robots_of_role(role: str) -> list[str]:
    """The registered robots whose adapter plays ``role`` (one whose adapter does not import
    is left out: it plays none)."""
    names = []
    for name in robot_names():
        try:
            adapter = _REGISTRY[name].adapter_class()
        except (ImportError, AttributeError, TypeError, ValueError):
            continue
        if issubclass(adapter, ROLES[role]):
            names.append(name)
    return names


def require_role(setting: str, name: str, role: str) -> None:
    """Refuse, in one line naming ``setting`` and the robots allowed there, a robot ``name``
    that is not registered or whose adapter does not play ``role``: a task's robot setting is
    checked with its config, before any scene is compiled or anything written."""
    if name not in _REGISTRY:
        problem = f"unknown robot {name!r}"
    else:
        try:
            adapter = _REGISTRY[name].adapter_class()
        except (ImportError, AttributeError, TypeError, ValueError) as err:
            raise ValueError(
                f"{setting}: robot {name!r} has no adapter that loads ({err})"
            ) from None
        if issubclass(adapter, ROLES[role]):
            return
        try:
            played = role_of(adapter)
            problem = f"{name!r} is {'an' if played[0] in 'aeiou' else 'a'} {played} robot"
        except ValueError:
            problem = f"{name!r} plays no role ({adapter.__name__} is none of {', '.join(ROLES)})"
    raise ValueError(f"{setting}: {problem}; allowed: {', '.join(robots_of_role(role))}")
