"""User code that registers tasks, robots or methods, made visible in every process.

A registration (``register_task``, ``register_robot``, ``register_method``) lives in the
process that ran it: a spawned environment worker, a reproduction-grid subprocess, a resumed run
or an evaluation would not know the user's task. So the project has one way in, honoured by
every command line, every worker and the checkpoint loader — :func:`load_plugins` imports, in
this order:

1. the entry points of installed packages in the groups :data:`ENTRY_POINT_GROUPS`
   (``[project.entry-points."maopg.tasks"] mytask = "mypkg.tasks"``): the module is imported,
   and a callable entry point is also called;
2. the modules named in the environment variable :data:`ENV_VAR` (``MAOPG_PLUGINS=mypkg.a,
   mypkg.b``);
3. the modules given to it (``--import MODULE`` on the command lines, a run's saved
   ``plugins``). A name ending in ``.py`` is imported from that file (recorded by its absolute
   path, so a resume from another directory finds it), its folder first on ``sys.path`` as
   Python puts a script's: the plugin imports the modules beside it as it would run as a
   script (and one of them shadows an installed module of its name, as beside a script). It
   is put there in every process that imports the file — by this function, which spawned
   workers, a resumed run and an evaluation of the run's checkpoint call too — so none of them
   fails on a module beside it.

Modules given by name are added to :data:`ENV_VAR` in this process's environment, which every
child process inherits (``spawn`` workers, grid subprocesses), so they import them too.

:func:`imported_plugins` lists what this process imported, each plugin's file with its SHA-256:
an evaluation records it, so that a result can be traced to the code that produced it.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import sys
from collections.abc import Iterable
from importlib.metadata import entry_points
from pathlib import Path

ENV_VAR = "MAOPG_PLUGINS"
ENTRY_POINT_GROUPS = ("maopg.tasks", "maopg.robots", "maopg.methods")

_LOADED: set[str] = set()


class PluginError(ImportError):
    """A plugin module could not be imported (the message names it and why)."""


def _point_key(group: str, name: str) -> str:
    """How an entry point is named among the plugins loaded."""
    return f"entry point {group}:{name}"


def _import(name: str) -> None:
    if name in _LOADED:
        return
    try:
        if name.endswith(".py"):
            path = Path(name).resolve()
            spec = importlib.util.spec_from_file_location(path.stem, path)
            if spec is None or spec.loader is None or not path.is_file():
                raise FileNotFoundError(f"no such file {path}")
            if str(path.parent) not in sys.path:  # the modules beside it (module docstring)
                sys.path.insert(0, str(path.parent))
            module = importlib.util.module_from_spec(spec)
            sys.modules[path.stem] = module
            spec.loader.exec_module(module)
        else:
            importlib.import_module(name)
    except Exception as err:  # the user's module: any failure is reported as its own
        raise PluginError(f"plugin {name!r} failed to import: {type(err).__name__}: {err}") from err
    _LOADED.add(name)


def env_plugins() -> list[str]:
    """The modules named in :data:`ENV_VAR` (comma- or path-separator-separated)."""
    text = os.environ.get(ENV_VAR, "")
    return [m.strip() for m in text.replace(os.pathsep, ",").split(",") if m.strip()]


def load_plugins(modules: Iterable[str] = ()) -> list[str]:
    """Import the entry points, :data:`ENV_VAR` and ``modules`` (see the module docstring);
    returns the modules imported by name. Importing the same plugin twice is a no-op."""
    for group in ENTRY_POINT_GROUPS:
        for point in entry_points(group=group):
            key = _point_key(group, point.name)
            if key in _LOADED:
                continue
            try:
                loaded = point.load()
                if callable(loaded):
                    loaded()
            except Exception as err:
                raise PluginError(f"{key} ({point.value}) failed: {err}") from err
            _LOADED.add(key)
    given = [str(Path(m).resolve()) if m.endswith(".py") else m for m in modules]
    named = list(dict.fromkeys([*env_plugins(), *given]))
    for name in named:
        _import(name)
    if named:
        os.environ[ENV_VAR] = ",".join(named)
    return named


def imported_plugins() -> list[dict[str, str | None]]:
    """Every plugin this process imported (:func:`load_plugins`), sorted by name, each as
    ``{"plugin": its name, "path": the file its module was read from, "sha256": that file's}``
    (an entry point as ``entry point GROUP:NAME``, with its module's file). The file is the
    module's own: the modules it imports in turn (those beside a ``.py`` plugin, a package's
    other modules) are not hashed. ``sha256`` is ``None`` where the file cannot be read (and
    ``path`` too for a module without one)."""
    modules = {
        _point_key(group, point.name): point.module
        for group in ENTRY_POINT_GROUPS
        for point in entry_points(group=group)
    }
    records = []
    for name in sorted(_LOADED):
        module = sys.modules.get(modules.get(name, name))
        path = name if name.endswith(".py") else getattr(module, "__file__", None)
        readable = path is not None and Path(path).is_file()
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest() if readable else None
        records.append({"plugin": name, "path": path, "sha256": digest})
    return records
