"""The settings reference (:mod:`maopg.experiment.run.settings_reference`): every field of every
settings dataclass of a run is listed, with its kind, default, bounds and meaning, in the
Markdown page and in ``python -m train --help``, which answers without importing torch, MuJoCo
or numpy."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

from maopg.env import OWN_ARGUMENTS
from maopg.experiment.run.config import NOT_RUN_FIELDS, RUN_SECTIONS, TrainConfig
from maopg.experiment.run.methods import section_classes
from maopg.experiment.run.settings_reference import settings_markdown, settings_sections
from maopg.tasks import task_entry, task_names


def _builtin_tasks() -> list[str]:
    """The tasks maopg registers itself (another test of this process may have imported a
    plugin's, which the ``--help`` of a fresh process does not list)."""
    return [t for t in task_names() if task_entry(t).config_class().__module__.startswith("maopg.")]


def _declared() -> dict[str, set[str]]:
    """Each section's settings as the dataclasses declare them, named as on a command line."""
    fields = {"": {f.name for f in dataclasses.fields(TrainConfig)} - set(NOT_RUN_FIELDS)}
    for name, cls in {**RUN_SECTIONS, **section_classes()}.items():
        fields[f"{name}."] = {f"{name}.{f.name}" for f in dataclasses.fields(cls)}
    for task in _builtin_tasks():
        cls = task_entry(task).config_class()
        fields[task] = {f"env.{f.name}" for f in dataclasses.fields(cls)} - {
            f"env.{key}" for key in OWN_ARGUMENTS
        }
    return fields


def test_every_field_of_every_settings_dataclass_is_in_the_reference():
    markdown = settings_markdown()
    listed = {s.name for section in settings_sections() for s in section.settings}
    for names in _declared().values():
        assert names <= listed
        for name in names:
            assert f"| `{name}` |" in markdown, name
    by_task = {
        section.title.rpartition(" ")[2]: {s.name for s in section.settings}
        for section in settings_sections()
        if section.title.startswith("env.") and section.title.rpartition(" ")[2] in _builtin_tasks()
    }
    assert by_task == {task: names for task, names in _declared().items() if task in by_task}
    assert set(by_task) >= set(_builtin_tasks())


def test_a_row_holds_kind_default_bounds_and_meaning():
    markdown = settings_markdown().splitlines()
    assert "| `ppo.epochs` | int | `10` | >= 1 | Passes of the PPO update over each batch. |" in (
        markdown
    )
    assert any(
        line.startswith("| `env.desk_spots` | [[float, float], [float, float]] | `[[")
        for line in markdown
    )
    assert any(
        line.startswith("| `ppo.clip` | float | `0.2` | >= 0, inf allowed | PPO's ratio clip")
        for line in markdown
    )
    # a registration's defaults and a method's fixed settings are the reference's too
    text = "\n".join(markdown)
    assert "mac-iac (maciaicc.critic=own)" in text and "async-rnn (ppo.recurrent=true)" in text
    assert "box_pushing_grid: ppo.explore_eps=1.0" in text
    # every built-in setting says what it does
    plugins = set(task_names()) - set(_builtin_tasks())
    undocumented = [
        s.name
        for sec in settings_sections()
        if sec.title.rpartition(" ")[2] not in plugins
        for s in sec.settings
        if not s.meaning
    ]
    assert undocumented == []


HELP = (
    "import json, sys\n"
    "from maopg.experiment.cli.train_cli import main\n"
    "try:\n"
    "    main(sys.argv[1:])\n"
    "except SystemExit:\n"
    "    pass\n"
    "print(json.dumps([m for m in ('torch', 'mujoco', 'numpy') if m in sys.modules]), "
    "file=sys.stderr)\n"
)


def _help(*argv: str) -> tuple[str, list[str]]:
    """``python -m train *argv --help``'s text, and the heavy modules it imported."""
    done = subprocess.run(
        [sys.executable, "-c", HELP, *argv, "--help"], capture_output=True, text=True, check=True
    )
    return done.stdout, json.loads(done.stderr.splitlines()[-1])


def test_train_help_lists_every_setting_without_importing_torch_or_mujoco():
    text, heavy = _help()
    assert heavy == []
    lines = text.splitlines()
    for names in _declared().values():
        for name in names:
            assert any(line.startswith(f"  {name}=") for line in lines), name
    assert "  ppo.epochs=10  (int, >= 1)" in lines
    assert "  dqn.buffer_size=50000  (int, >= 1)" in lines


def test_a_plugins_task_settings_are_in_its_help():
    text, _ = _help("--import", "examples.berries")
    assert "env.* for --task berries" in text
    assert "  env.ripen_prob=0.08  (float, >= 0, <= 1)" in text.splitlines()
