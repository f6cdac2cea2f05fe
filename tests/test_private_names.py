"""A module's private names (``_name``) stay inside its package: no module of ``maopg`` outside
the package that defines a private name, and no benchmark or example, imports it or reads it
off an imported module. What another package needs is public, with a docstring; a private name
can then change without a search."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("maopg", "bench", "examples")


def _package_of(module: str) -> str:
    """The package that holds ``module`` (``maopg.sim`` for ``maopg.sim.render``)."""
    path = ROOT / Path(*module.split("."))
    return module if (path / "__init__.py").exists() else module.rpartition(".")[0]


def crossings(source: str, package: str) -> list[str]:
    """The private names ``source`` (a module of ``package``) takes from another package of
    ``maopg``: ``from maopg.x import _y``, ``import maopg.x._y``, ``maopg.x._y`` and, after
    ``from maopg import x`` or ``import maopg.x as x``, ``x._y``."""
    found = []
    aliases: dict[str, str] = {}  # a name bound to a maopg module -> that module
    nodes = list(ast.walk(ast.parse(source)))
    for node in nodes:
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if not node.module.startswith("maopg"):
                continue
            for alias in node.names:
                if alias.name.startswith("_") and _package_of(node.module) != package:
                    found.append(f"{alias.name} from {node.module}")
                aliases[alias.asname or alias.name] = f"{node.module}.{alias.name}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if not alias.name.startswith("maopg"):
                    continue
                parts = alias.name.split(".")
                private = [p for p in parts if p.startswith("_") and not p.startswith("__")]
                if private and _package_of(".".join(parts[:-1])) != package:
                    found.append(f"module {alias.name}")
                aliases[alias.asname or parts[0]] = alias.name if alias.asname else parts[0]
    for node in nodes:
        if not (isinstance(node, ast.Attribute) and node.attr.startswith("_")):
            continue
        if node.attr.startswith("__"):
            continue
        chain = []
        value = node.value
        while isinstance(value, ast.Attribute):
            chain.append(value.attr)
            value = value.value
        if isinstance(value, ast.Name) and value.id in aliases:
            module = ".".join([aliases[value.id], *reversed(chain)])
            if module.startswith("maopg") and _package_of(module) != package:
                found.append(f"{node.attr} of {module}")
    return found


def test_no_private_name_crosses_a_package():
    found = []
    for source in SOURCES:
        for path in sorted((ROOT / source).rglob("*.py")):
            package = ".".join(path.relative_to(ROOT).parent.parts)
            found += [
                f"{path.relative_to(ROOT)}: {c}" for c in crossings(path.read_text(), package)
            ]
    assert not found, "\n".join(found)


def test_the_walk_sees_each_kind_of_crossing():
    """The test's premise, on sources written for it."""
    assert _package_of("maopg.sim.render") == "maopg.sim"
    cases = {
        "from maopg.sim.render import _fit_offscreen_buffer": ["_fit_offscreen_buffer"],
        "import maopg.sim.render as r\nr._fit_offscreen_buffer": ["_fit_offscreen_buffer"],
        "from maopg.sim import render\nrender._fit_offscreen_buffer": ["_fit_offscreen_buffer"],
        "import maopg\nmaopg.sim.render._fit_offscreen_buffer": ["_fit_offscreen_buffer"],
        "from maopg.sim.render import make_renderer": [],
    }
    for source, names in cases.items():
        found = crossings(source, "bench.perf")
        assert len(found) == len(names) and all(
            n in f for n, f in zip(names, found, strict=True)
        ), source
    # inside its own package a private name is the package's business
    assert crossings("from maopg.sim.render import _fit_offscreen_buffer", "maopg.sim") == []
