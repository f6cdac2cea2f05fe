"""The task registry: built-in entries, user registration, lazy imports and config checks."""

from __future__ import annotations

import subprocess
import sys

import pytest

from maopg.tasks import TaskEntry, make_config, register_task, registry, task_entry, task_names
from maopg.tasks.tool_delivery.task import ToolDelivery


@pytest.fixture
def private_registry(monkeypatch):
    """A copy of the registry, so tasks registered by a test do not outlive it."""
    monkeypatch.setattr(registry, "_TASKS", dict(registry._TASKS))


def test_built_in_tasks_declare_what_the_project_looks_up() -> None:
    assert {"tool_delivery", "water_filling"} <= set(task_names())
    td, wf = task_entry("tool_delivery"), task_entry("water_filling")
    assert dict(td.train_defaults) == {
        "batch_ticks": 200,
        "total_samples": 100_000,
        "images": False,
    }
    assert dict(wf.train_defaults) == {
        "batch_ticks": 2000,
        "total_samples": 200_000,
        "images": True,
        "backend": "processes",
    }
    for entry in (td, wf):
        assert callable(entry.scripted_factory()) and callable(entry.panel_fn())
        assert entry.config_class() is entry.task_class().Config


def test_importing_the_registry_imports_no_simulation_code() -> None:
    code = (
        "import sys, maopg.tasks as t; t.make_config('water_filling', {'max_ticks': 5}); "
        "print(sorted(m for m in sys.modules if m.startswith('maopg.tasks.')"
        " and m.endswith(('.task', '.scene', '.options', '.scripted'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_unknown_tasks_and_config_keys_are_named() -> None:
    with pytest.raises(ValueError, match=r"unknown task 'nope'; known tasks: .*tool_delivery"):
        task_entry("nope")
    with pytest.raises(
        ValueError,
        match=r"unknown setting 'env\.max_tick' of task 'tool_delivery': did you mean "
        r"'env\.max_ticks'\?$",
    ):
        make_config("tool_delivery", {"max_tick": 3})
    assert make_config("tool_delivery", {"max_ticks": 3}).max_ticks == 3


@pytest.mark.usefixtures("private_registry")
def test_a_users_task_registers_by_class_or_by_lazy_name() -> None:
    entry = register_task("my_delivery", ToolDelivery)
    assert isinstance(entry, TaskEntry) and entry.config is ToolDelivery.Config
    assert task_entry("my_delivery") is entry and "my_delivery" in task_names()
    assert entry.scripted_factory() is None and entry.state_lines_fn() is None
    assert entry.panel_fn() is None
    lazy = register_task("lazy_delivery", "maopg.tasks.tool_delivery.task:ToolDelivery")
    assert lazy.config == "maopg.tasks.tool_delivery.task:ToolDelivery.Config"
    assert lazy.config_class() is ToolDelivery.Config and lazy.task_class() is ToolDelivery
    with pytest.raises(ValueError, match="already registered"):
        register_task("my_delivery", ToolDelivery)
    replaced = register_task(
        "my_delivery", ToolDelivery, train_defaults={"batch_ticks": 100}, overwrite=True
    )
    assert task_entry("my_delivery") is replaced


@pytest.mark.usefixtures("private_registry")
def test_the_grid_keywords_of_earlier_releases_say_where_they_went() -> None:
    """Seeds, thresholds and per-method grid settings are a study's now; a plugin that still
    passes them learns where to put them, and a misspelt keyword stays a ``TypeError``."""
    with pytest.raises(ValueError, match=r"register_task\(grid_seeds=, threshold=\.\.\.\).*study"):
        register_task("old_style", ToolDelivery, threshold=1.0, grid_seeds=(0,))
    with pytest.raises(TypeError, match="scriptd"):
        register_task("old_style", ToolDelivery, scriptd=None)
    assert "old_style" not in task_names()


@pytest.mark.usefixtures("private_registry")
def test_bad_registrations_fail_with_what_is_wrong() -> None:
    class Bare:
        """Has no ``Config`` to default to."""

    with pytest.raises(ValueError, match="Bare has no Config attribute; pass config="):
        register_task("bare", Bare)
    broken = register_task("broken", "maopg.tasks.tool_delivery.task:NoSuchTask")
    with pytest.raises(ValueError, match="has no attribute 'NoSuchTask'"):
        broken.task_class()
    wrong = register_task("wrong", "maopg.tasks.tool_delivery.config:Config", config="builtins:int")
    with pytest.raises(TypeError, match="not a Task class"):
        wrong.task_class()
    with pytest.raises(TypeError, match="not a TaskConfig"):
        wrong.config_class()
