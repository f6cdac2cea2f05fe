"""A module's private names (``_name``) stay inside its package: no module of ``maopg`` outside
the package that defines a private name, and no benchmark or example, imports it. What another
package needs is public, with a docstring; a private name can then change without a search."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("maopg", "bench", "examples")


def _package_of(module: str) -> str:
    """The package that holds ``module`` (``maopg.sim`` for ``maopg.sim.render``)."""
    path = ROOT / Path(*module.split("."))
    return module if (path / "__init__.py").exists() else module.rpartition(".")[0]


def _importer_package(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).parent.parts)


def test_no_private_name_is_imported_from_another_package():
    crossings = []
    for source in SOURCES:
        for path in sorted((ROOT / source).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if not (isinstance(node, ast.ImportFrom) and node.level == 0 and node.module):
                    continue
                if not node.module.startswith("maopg"):
                    continue
                private = [a.name for a in node.names if a.name.startswith("_")]
                if private and _importer_package(path) != _package_of(node.module):
                    where = path.relative_to(ROOT)
                    crossings.append(f"{where} imports {private} from {node.module}")
    assert not crossings, "\n".join(crossings)


def test_the_walk_sees_a_crossing():
    """The test's premise: a private import from another package is recognised as one."""
    assert _package_of("maopg.sim.render") == "maopg.sim"
    assert _importer_package(ROOT / "bench" / "culling.py") == "bench"
