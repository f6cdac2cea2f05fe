"""Config files: ``--config run.yaml`` (or ``.json``) holds the settings ``key=value`` gives.

The keys are a run's ``config.json``'s (which is itself a config file): run fields at the top,
sections nested (``ppo: {epochs: 5}``, ``env: {max_ticks: 100}``) or dotted
(``ppo.epochs: 5``, ``env.max_ticks: 100``). Reading one needs neither torch nor MuJoCo, so the
plotting and table commands read saved configs with it too.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import yaml

from maopg.experiment.run.migration import migrate_config

CONFIG_FORMATS = {".json": "JSON", ".yaml": "YAML", ".yml": "YAML"}
"""Config file suffixes and the format each is read as."""


class _YAMLLoader(yaml.SafeLoader):
    """YAML as JSON reads numbers: PyYAML follows YAML 1.1, where ``1e-3`` (no dot) is a
    string, which would make ``ppo.lr: 1e-3`` a kind error."""


_YAMLLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def read_config_file(path: str | Path) -> dict[str, Any]:
    """The settings of a ``.yaml``/``.yml``/``.json`` config file as
    :func:`maopg.experiment.run.config.merge` takes them (:func:`nest_settings`), in the current
    schema (:func:`~maopg.experiment.run.migration.migrate_config`: a run directory of an earlier
    release reads as today's); an unreadable file, bad syntax, anything but a mapping or a
    schema this version does not know is a ``ValueError`` naming the file. Values keep the
    file's kinds: the config checks them."""
    path = Path(path)
    kind = CONFIG_FORMATS.get(path.suffix.lower())
    if kind is None:
        raise ValueError(f"config file {path}: expected a name ending {sorted(CONFIG_FORMATS)}")
    try:
        text = path.read_text()
    except OSError as err:
        raise ValueError(f"config file {path}: {err.strerror or err}") from None
    try:
        data = json.loads(text) if kind == "JSON" else yaml.load(text, Loader=_YAMLLoader)
    except (json.JSONDecodeError, yaml.YAMLError) as err:
        raise ValueError(f"{path} is not valid {kind}: {' '.join(str(err).split())}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping of settings, got {type(data).__name__}")
    settings = nest_settings(data, str(path))
    try:
        return migrate_config(settings)
    except ValueError as err:
        raise ValueError(f"{path}: {err}") from None


def nest_settings(data: dict[str, Any], where: str) -> dict[str, Any]:
    """``{"ppo.epochs": 5, "env": {"max_ticks": 100}}`` → ``{"ppo": {"epochs": 5},
    "env_overrides": {"max_ticks": 100}}``: dotted keys nested, the ``env`` section under the
    field that holds it (a saved ``config.json``'s ``env_overrides`` is read as it is)."""
    values: dict[str, Any] = {}
    for key, value in data.items():
        section, dot, name = str(key).partition(".")
        section = "env_overrides" if section == "env" else section
        if dot or isinstance(value, dict):
            nested = values.setdefault(section, {})
            if not isinstance(nested, dict):
                raise ValueError(f"{where}: {section} is both a setting and a section")
            nested.update({name: value} if dot else value)
        elif section in values:
            raise ValueError(f"{where}: {section} is both a setting and a section")
        else:
            values[section] = value
    return values
