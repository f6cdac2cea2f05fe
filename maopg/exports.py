"""Names imported on first use: a registry's ``"package.module:Attr"`` references
(:func:`resolve`) and packages whose public names load when read (PEP 562).

A package ``__init__`` that imports every module it exports makes each of its modules cost as
much as the heaviest: importing the plain dataclasses of :mod:`maopg.learner.sections` would
load torch with ``maopg.learner``, and a task's settings MuJoCo with ``maopg.tasks``. A package
that declares its exports with :func:`lazy_exports` instead keeps ``from maopg.learner import
MAPPO`` working while its light modules stay light: the command line's ``--help`` and the
settings reference read every setting without importing torch or MuJoCo.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Sequence
from typing import Any


def resolve(reference: Any) -> Any:
    """Import ``"package.module:Attr.attr"`` (a registry's lazy reference to a class or a
    function, so that registering imports none of its code); any other value is returned as
    it is."""
    if not isinstance(reference, str):
        return reference
    module, sep, path = reference.partition(":")
    if not sep or not path:
        raise ValueError(f"expected 'package.module:Attr', got {reference!r}")
    value: Any = importlib.import_module(module)
    for attr in path.split("."):
        try:
            value = getattr(value, attr)
        except AttributeError:
            raise ValueError(
                f"{reference!r}: {type(value).__name__} has no attribute {attr!r}"
            ) from None
    return value


def lazy_exports(
    package: str, references: Sequence[str]
) -> tuple[list[str], Callable[[str], Any], Callable[[], list[str]]]:
    """``(__all__, __getattr__, __dir__)`` for ``package``, which exports the ``Name`` of each
    ``"package.module:Name"`` of ``references``, imported from its module when first read."""
    homes = {reference.partition(":")[2]: reference for reference in references}

    def __getattr__(name: str) -> Any:
        if name not in homes:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = resolve(homes[name])
        setattr(sys.modules[package], name, value)  # read once: later reads skip this hook
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *homes})

    return sorted(homes), __getattr__, __dir__
