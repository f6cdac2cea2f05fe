"""The package's dependency direction: sim → options → tasks → env → policy → learner →
experiment, and inside experiment run → evaluation → training → studies → cli → the package's
own facade, with no import cycles (docs/DESIGN.md, "Layers").

Every import is counted — at module level, inside functions (lazy imports), under
``TYPE_CHECKING``, and the lazy ``"maopg.module:Attr"`` references of the registries — because
each is a dependency of the code, whether or not it runs at import time. Parsing the sources
needs no import to succeed; a second test imports each layer in a fresh interpreter and checks
that nothing above it was loaded (what an import really pulls in, packages' ``__init__``
included).
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

import maopg

PACKAGE = Path(maopg.__file__).resolve().parent
LAYERS = (
    "sim",
    "options",
    "tasks",
    "env",
    "policy",
    "learner",
    "experiment.run",
    "experiment.evaluation",
    "experiment.training",
    "experiment.studies",
    "experiment.cli",
    "experiment",
)
"""Subpackages from the bottom up; a module may import only its own layer and those below.
``experiment`` itself is its ``__init__``: the facade (``load_policy``, ``register_method``)
that imports from its subpackages on first use."""


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _layer(module: str) -> int:
    """0 for the package root's own modules (``maopg`` itself), else 1 + the index of the
    innermost layer that holds it."""
    name = module.partition(".")[2]
    held = [layer for layer in LAYERS if name == layer or name.startswith(f"{layer}.")]
    return 1 + LAYERS.index(max(held, key=len)) if held else 0


LAZY_REFERENCE = re.compile(r"^(maopg(?:\.\w+)+):\w")
"""A registry's lazily imported ``"package.module:Attr"``."""


def _text(node: ast.Constant | ast.JoinedStr, module: str) -> str:
    """A string constant, or an f-string with ``{__name__}`` filled in (other fields empty)."""
    if isinstance(node, ast.Constant):
        return node.value if isinstance(node.value, str) else ""
    parts = []
    for value in node.values:
        if isinstance(value, ast.Constant):
            parts.append(str(value.value))
        elif isinstance(value.value, ast.Name) and value.value.id == "__name__":
            parts.append(module)
    return "".join(parts)


def _imports(module: str) -> set[str]:
    """The ``maopg`` modules that ``module`` imports (a name imported from a package resolves
    to the submodule when one of that name exists)."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, *([base] if base else [])])
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                found.add(sub if sub in MODULES else base)
        elif isinstance(node, ast.Constant | ast.JoinedStr):
            reference = LAZY_REFERENCE.match(_text(node, module))
            if reference:
                found.add(reference.group(1))
    return {m for m in found if m in MODULES and m != module}


GRAPH = {module: _imports(module) for module in MODULES}


def test_the_layers_are_the_packages_subpackages():
    def subpackages(folder: Path) -> set[str]:
        return {p.name for p in folder.iterdir() if (p / "__init__.py").exists()}

    assert subpackages(PACKAGE) == {layer.split(".")[0] for layer in LAYERS}
    inner = {layer.split(".")[1] for layer in LAYERS if "." in layer}
    assert subpackages(PACKAGE / "experiment") == inner


def test_every_import_points_down_or_sideways():
    upward = [
        f"{module} ({LAYERS[_layer(module) - 1] if _layer(module) else 'root'}) imports "
        f"{target} ({LAYERS[_layer(target) - 1]})"
        for module, targets in GRAPH.items()
        for target in sorted(targets)
        if _layer(target) > _layer(module)
    ]
    assert not upward, "\n".join(upward)


def test_there_is_no_import_cycle():
    """Tarjan's strongly connected components: any component of two or more is a cycle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for target in GRAPH[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for module in GRAPH:
        if module not in index:
            visit(module)
    assert not cycles, cycles


def test_the_package_never_imports_the_command_line_folders():
    """``train/`` and ``eval/`` are thin entry points of a clone, not installed packages."""
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            assert not [n for n in names if n.split(".")[0] in ("train", "eval")], module


def test_the_walk_sees_lazy_and_registry_imports():
    """The test's own premise: a function-level import and a registry string are edges."""
    assert "maopg.env" in GRAPH["maopg.env.vector_base"]
    assert "maopg.env.ray_backend" in GRAPH["maopg.env.vector"]
    assert "maopg.experiment.training.trainer" in GRAPH["maopg.experiment.cli.train_cli"]
    assert "maopg.tasks.tool_delivery.task" in GRAPH["maopg.tasks.tool_delivery"]


def test_a_module_belongs_to_its_innermost_layer():
    assert _layer("maopg.plugins") == 0
    assert _layer("maopg.sim.render") == 1 + LAYERS.index("sim")
    assert _layer("maopg.experiment.run.config") == 1 + LAYERS.index("experiment.run")
    assert _layer("maopg.experiment.cli.eval_cli") == 1 + LAYERS.index("experiment.cli")
    assert _layer("maopg.experiment") == len(LAYERS)


@pytest.mark.parametrize("layer", LAYERS)
def test_importing_a_layer_loads_nothing_above_it(layer):
    names = sorted(m for m in MODULES if _layer(m) == 1 + LAYERS.index(layer))
    code = (
        "import importlib, sys\n"
        f"for name in {names!r}: importlib.import_module(name)\n"
        "print('\\n'.join(m for m in sys.modules if m.startswith('maopg')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    # a parent package's __init__ loads with its subpackages whatever its layer (the facade
    # ``maopg.experiment``); what it imports in turn would show here on its own
    parents = {n.rsplit(".", k)[0] for n in names for k in range(1, n.count(".") + 1)}
    loaded = [m for m in out.stdout.split() if m in MODULES and m not in parents]
    above = [m for m in loaded if _layer(m) > 1 + LAYERS.index(layer)]
    assert not above, above
