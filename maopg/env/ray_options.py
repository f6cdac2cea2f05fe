"""The ``ray`` backend's settings (``ray.*``) and whether Ray is installed, without Ray, MuJoCo
or the backend itself (:mod:`maopg.env.ray_backend`): a run's config validates them, and the
command line's ``--help`` lists them, before anything is built."""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from typing import ClassVar

from maopg.extras import install_hint
from maopg.settings import Settings, setting


def missing_ray() -> str:
    """The error of ``backend=ray`` without Ray: how to install it (:func:`install_hint`)."""
    return f"backend=ray needs Ray: {install_hint('ray')}"


def ray_available() -> bool:
    """Whether Ray can be imported (without importing it: that takes a while)."""
    return importlib.util.find_spec("ray") is not None


@dataclass(frozen=True)
class RayOptions(Settings):
    """The ``ray.*`` settings of a run: where the actors run, not what they compute (a resumed
    run may change them)."""

    PREFIX: ClassVar[str] = "ray."

    address: str | None = None
    """``None``: start a local Ray instance; ``auto``: join this machine's cluster; else the
    address given to ``ray.init`` (``HOST:6379``, ``ray://HOST:10001``)."""
    cpus_per_actor: float = setting(1.0, gt=0.0)
    """Logical CPUs each actor reserves (Ray places actors by them)."""
    max_replacements: int = setting(8, ge=0)
    """Dead actors replaced in one run before giving up."""
    direct: bool = True
    """Exchange option steps with the actors over direct TCP connections
    (:mod:`maopg.env.ray_backend`); ``false``: one Ray actor call per step."""

    def validate(self) -> None:
        super().validate()
        if self.address not in (None, "auto"):
            host, sep, port = self.address.removeprefix("ray://").rpartition(":")
            if not (host and sep and port.isdigit()):
                raise ValueError(
                    f"ray.address={self.address!r}: expected HOST:PORT, ray://HOST:PORT or auto"
                )
