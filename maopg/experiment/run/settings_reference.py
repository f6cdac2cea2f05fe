"""The settings reference: every setting a run takes, with its kind, default, bounds and meaning,
read from the settings dataclasses themselves (:mod:`maopg.settings`), so it cannot drift from
what the config accepts.

One generator, :func:`settings_sections`, feeds two renderings: :func:`settings_help`, the
``--help`` of ``python -m train`` (the first sentence of each meaning), and
:func:`settings_markdown`, the documentation's reference page (``docs/reference/settings.md``,
written by the MkDocs build; every meaning whole). The sections are the run's own fields, the
run-wide sections (:data:`~maopg.experiment.run.config.RUN_SECTIONS`), each learner's section
with the methods that read it, and each registered task's ``env.*`` settings, plugins' included
once they are imported. A field's meaning is the docstring under it in its class's source (the
nearest class of its MRO that has one). Nothing here imports torch or MuJoCo: ``--help`` answers
at once.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import itertools
import json
import re
import shutil
import textwrap
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from maopg.env import OWN_ARGUMENTS
from maopg.experiment.run.config import NOT_RUN_FIELDS, RUN_SECTIONS, TrainConfig
from maopg.experiment.run.methods import get_method, method_names, section_classes
from maopg.settings import describe_kind, field_bounds, field_hints
from maopg.tasks import task_entry, task_names


@dataclass(frozen=True)
class Setting:
    """One row of the reference."""

    name: str
    """As the command line writes it: ``num_envs``, ``ppo.epochs``, ``env.max_ticks``."""
    kind: str
    """``int``, ``float or null``, ``[float, float]``."""
    default: str
    """As a config file or ``key=value`` writes it (``true``, ``null``, ``[0.9, 1.8]``)."""
    bounds: str
    """What the value must be beyond its kind (``>= 1``, ``one of cpu, cuda``), or empty."""
    meaning: str
    """The field's docstring as plain text with ``code`` marks (empty where it has none)."""


@dataclass(frozen=True)
class Section:
    """The settings of one config dataclass, as a heading and a table."""

    title: str
    about: str
    settings: tuple[Setting, ...]


def settings_sections() -> list[Section]:
    """Every setting of a run, section by section: the run's fields, the run-wide sections,
    the learners' sections and each registered task's ``env.*`` settings."""
    run = Section(
        "Run settings",
        "The run's own fields: key=value, or a top-level key of a --config file.",
        _settings(TrainConfig, "", skip=NOT_RUN_FIELDS),
    )
    run_wide = [
        Section(f"{name}.*", _first_sentence(_plain(cls.__doc__)), _settings(cls, f"{name}."))
        for name, cls in RUN_SECTIONS.items()
    ]
    learners = [
        Section(f"{name}.*", _learner_about(name, cls), _settings(cls, f"{name}."))
        for name, cls in section_classes().items()
    ]
    tasks = [_task_section(task) for task in task_names()]
    return [run, *run_wide, *learners, *tasks]


def settings_markdown() -> str:
    """The whole reference as a Markdown page: a table per section (name, kind, default,
    bounds, meaning)."""
    lines = [
        "# Settings reference",
        "",
        "Every setting of `python -m train` (`maopg-train`), generated from the settings "
        "dataclasses (`maopg.experiment.run.settings_reference`). On the command line a "
        "setting is `key=value` (`num_envs=8`, `ppo.epochs=5`, `env.max_ticks=100`); in a "
        "`--config` file (YAML or JSON) the same keys, sections nested (`ppo: {epochs: 5}`) "
        "or dotted. A method reads its own learner section only; each task has its own "
        "`env.*` settings. `python -m train --help` lists the same settings.",
    ]
    for section in settings_sections():
        title = section.title.replace("*", "\\*")  # ray.*: a star, not emphasis
        lines += ["", f"## {title}", "", _cell(section.about), ""]
        lines += ["| setting | kind | default | bounds | meaning |", "|---|---|---|---|---|"]
        lines += [
            "| "
            + " | ".join(
                [
                    f"`{s.name}`",
                    _cell(s.kind),
                    f"`{_cell(s.default)}`",
                    _cell(s.bounds),
                    _cell(s.meaning),
                ]
            )
            + " |"
            for s in section.settings
        ]
    return "\n".join(lines) + "\n"


def settings_help() -> str:
    """The reference for ``--help``: per setting a line ``name=default  (kind, bounds)`` and
    the first sentence of its meaning, wrapped to the terminal."""
    width = min(shutil.get_terminal_size().columns, 100) - 2
    lines: list[str] = []
    for section in settings_sections():
        lines += ["", *textwrap.wrap(f"{section.title}: {section.about}", width)]
        for s in section.settings:
            kind = ", ".join(part for part in (s.kind, s.bounds) if part)
            lines.append(f"  {s.name}={s.default}  ({kind})")
            lines += textwrap.wrap(
                _first_sentence(s.meaning), width, initial_indent=" " * 6, subsequent_indent=" " * 6
            )
    return "\n".join(lines)


def _settings(
    cls: type, prefix: str, *, skip: Iterable[str] = (), defaults: Mapping[str, Any] | None = None
) -> tuple[Setting, ...]:
    """The rows of ``cls``'s fields but ``skip``, their defaults overridden by ``defaults``."""
    hints = field_hints(cls)
    docs = field_docs(cls)
    defaults = defaults or {}
    return tuple(
        Setting(
            name=prefix + item.name,
            kind=describe_kind(hints[item.name]) if item.name in hints else "",
            default=_value(defaults[item.name] if item.name in defaults else _default(item)),
            bounds=field_bounds(cls, item.name).describe(),
            meaning=_plain(docs.get(item.name, "")),
        )
        for item in dataclasses.fields(cls)
        if item.name not in skip
    )


def _default(item: dataclasses.Field) -> Any:
    if item.default_factory is not dataclasses.MISSING:
        return item.default_factory()
    return item.default


def _value(value: Any) -> str:
    """``value`` as a config file writes it (JSON's spelling; a string bare)."""
    if isinstance(value, str):
        return value
    if isinstance(value, tuple):
        value = json.loads(json.dumps(value))  # nested tuples as lists
    return json.dumps(value)


def _learner_about(name: str, cls: type) -> str:
    """A learner section's class docstring (its first sentence), the methods that read it (with
    the settings a method fixes) and what tasks default in it."""
    methods = []
    for method in (get_method(m) for m in method_names()):
        if method.section == name:
            fixed = ", ".join(f"{name}.{key}={_value(v)}" for key, v in method.settings)
            methods.append(f"{method.name} ({fixed})" if fixed else method.name)
    prefix = f"{name}."
    by_task = []
    for task in task_names():
        own = [(k, v) for k, v in task_entry(task).train_defaults.items() if k.startswith(prefix)]
        if own:
            by_task.append(f"{task}: " + ", ".join(f"{k}={_value(v)}" for k, v in own))
    parts = [
        _first_sentence(_plain(cls.__doc__)),
        f"Read by --method {', '.join(methods)}.",
    ]
    if by_task:
        parts.append(f"Tasks' defaults: {'; '.join(by_task)}.")
    return " ".join(parts)


def _task_section(task: str) -> Section:
    """Task ``task``'s ``env.*`` settings at its registration's defaults, but those a run sets
    from its own fields (:data:`maopg.env.OWN_ARGUMENTS`)."""
    entry = task_entry(task)
    cls = entry.config_class()
    trained = ", ".join(f"{key}={_value(v)}" for key, v in entry.train_defaults.items())
    about = _first_sentence(_plain(cls.__doc__))
    if trained:
        about += f" Training defaults: {trained}."
    settings = _settings(cls, "env.", skip=OWN_ARGUMENTS, defaults=entry.defaults)
    return Section(f"env.* for --task {task}", about, settings)


@cache
def field_docs(cls: type) -> dict[str, str]:
    """The docstring under each field of dataclass ``cls`` in its source, a subclass's over its
    base's (a field redeclared without one keeps its base's); none where the source cannot be
    read (a class made at run time)."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if "__dataclass_fields__" in vars(klass):
            docs.update(_own_docs(klass))
    return docs


def _own_docs(cls: type) -> dict[str, str]:
    """The docstrings under the fields ``cls``'s own class body declares."""
    try:
        module = _module_tree(inspect.getsourcefile(cls) or "")
    except (OSError, TypeError, SyntaxError):
        return {}
    node: ast.AST = module
    for name in cls.__qualname__.split("."):
        node = next(
            (
                n
                for n in getattr(node, "body", [])
                if isinstance(n, ast.ClassDef) and n.name == name
            ),
            ast.Module(body=[], type_ignores=[]),
        )
    statements = getattr(node, "body", [])
    docs = {}
    for statement, following in itertools.pairwise(statements):
        if (
            isinstance(statement, ast.AnnAssign)
            and isinstance(statement.target, ast.Name)
            and isinstance(following, ast.Expr)
            and isinstance(following.value, ast.Constant)
            and isinstance(following.value.value, str)
        ):
            docs[statement.target.id] = inspect.cleandoc(following.value.value)
    return docs


@cache
def _module_tree(path: str) -> ast.Module:
    """A source file's syntax tree, parsed once however many of its classes are read."""
    return ast.parse(Path(path).read_text(), path)


ROLE = re.compile(r":[\w:]+:`(~?)([^`<]*?)\s*(?:<([^>`]+)>)?`")
"""A Sphinx cross-reference: ``:class:`~pkg.Name```, ``:mod:`text <pkg.mod>```."""


def _plain(text: str | None) -> str:
    """A docstring on one line: Sphinx roles as the name they show, ````code```` as
    ```code```, whitespace collapsed."""

    def shown(match: re.Match[str]) -> str:
        tilde, target, _ = match.groups()
        return f"`{target.rpartition('.')[2] if tilde else target}`"

    text = ROLE.sub(shown, text or "").replace("``", "`")
    return " ".join(text.split())


SENTENCE_MARKS = re.compile(r"[()]|\.(?= |$)")
"""What ends a sentence (a full stop before a space or the end) and the brackets around one
that does not."""


def _first_sentence(text: str) -> str:
    """``text`` up to its first full stop outside brackets (the whole of it if none)."""
    depth = 0
    for mark in SENTENCE_MARKS.finditer(text):
        if mark.group() == ".":
            if depth <= 0:
                return text[: mark.end()]
        else:
            depth += 1 if mark.group() == "(" else -1
    return text


def _cell(text: str) -> str:
    """``text`` inside a Markdown table cell."""
    return text.replace("|", "\\|")
