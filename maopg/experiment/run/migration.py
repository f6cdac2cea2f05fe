"""Everything maopg wrote before loads: configs and checkpoints brought to today's schema, here.

A saved config (``config.json``, any config file) and a checkpoint record the schema they were
written in (``schema``); those written before schemas existed are schema 1. Reading one brings
it to the current schema one step at a time, in this module and nowhere else, so the rest of
the code reads today's layout only, and a new layout is one more step here.

Config schema 1 → 2: MAPPO's hyper-parameters were flat fields (``epochs``) before the
``ppo`` section existed, and configs of that time saved every learner's section (a ``dqn``
section in an ``async`` run's config). The flat keys move into ``ppo`` (dropped for Mac-DQN,
whose learner never read them) and the other learner's section is dropped. A schema-1 config
without flat keys (sections already) is read as it is.

Config schema 2 → 3: exploration by ε-mixed sampling (``ppo.explore_*``) came with a task
whose training defaults turn it on (the Box Pushing grid). A MAPPO section saved in schema 2
trained without exploration and says nothing of it, so every exploration setting is read as
off (:data:`EXPLORATION_OFF`): an earlier run resumes as it trained, bit for bit. A file
without a ``schema`` key — written by hand, or saved before schemas, when no task explored by
default — is read as it is, so the task's defaults apply to what it leaves unset.

Checkpoint schema 1 → 2: the environments' entry was ``sampler``; the config it holds is
migrated as a schema-1 config. Checkpoint schema 2 → 3: its config, as config 2 → 3 (the
learner's finished-episode count, new with exploration, is 0 where absent). Checkpoint schema
3 → 4: the entries are the same; the checksum saved with them covers them all, the config
included, where schemas 2 and 3 checksummed the tensors alone
(:mod:`maopg.learner.checkpoint`). A checkpoint's config is in its checkpoint's schema.

Which checksum a checkpoint must carry follows from its schema (:func:`read_checkpoint`, the
one way the trainer and the evaluation read a checkpoint): from schema 4 the one over every
entry; in schemas 2 and 3 at least the one over the tensors; only a schema-1 checkpoint may
carry none — the earliest were written before checkpoints carried a checksum — and it then
loads unverified, as it always did. A checkpoint whose checksum was deleted is refused, unless
its ``schema`` entry was deleted too: it then passes for one of the earliest, which nothing
tells apart from them.

A command-line spelling of an earlier release (``epochs=5``, ``--set``) is not a saved file: the
command lines read it with one deprecation line
(:func:`maopg.experiment.run.config.parse_overrides`).
"""

from __future__ import annotations

import os
from typing import Any

SCHEMA_KEY = "schema"
CONFIG_SCHEMA = 3
"""The layout :meth:`~maopg.experiment.run.config.TrainConfig.save` writes."""
CHECKPOINT_SCHEMA = 4
"""The layout the trainer's checkpoints are written in."""
WHOLE_CHECKSUM_SCHEMA = 4
"""The first checkpoint schema whose checksum covers every entry, not the tensors alone."""

FLAT_PPO_KEYS = frozenset(
    {
        "adam_eps",
        "chunk_length",
        "clip",
        "critic_lr",
        "discount",
        "ent_coef",
        "ent_coef_end",
        "ent_decay",
        "epochs",
        "gae_lambda",
        "huber_delta",
        "lr",
        "max_grad_norm",
        "memory_norm",
        "normalize_advantages",
        "num_minibatches",
        "option_history",
        "recurrent",
        "value_clip",
        "value_coef",
        "value_norm",
    }
)
"""MAPPO's hyper-parameters, whose flat spelling (``epochs``) schema 1 and the command line of
earlier releases accepted. Fixed here, not read from today's ``PPOConfig``: the spelling
belongs to the releases that wrote it."""
SCHEMA_1_SECTIONS = ("ppo", "dqn")
"""The learner sections a schema-1 config could hold."""
EXPLORATION_OFF = {
    "explore_eps": 0.0,
    "explore_eps_end": 0.0,
    "explore_decay": 0,
    "explore_unit": "samples",
    "explore_form": "agent",
    "explore_ratio": "mixture",
}
"""MAPPO's exploration settings as schema 2 trained (none): fixed here, not read from today's
``PPOConfig`` defaults, which a task's training defaults override."""


def _schema(data: dict[str, Any], current: int, what: str) -> int:
    schema = data.get(SCHEMA_KEY, 1)
    if not isinstance(schema, int) or not 1 <= schema <= current:
        raise ValueError(
            f"{what} schema {schema!r}: this maopg reads schemas 1 to {current} "
            "(a newer maopg wrote it?)"
        )
    return schema


def migrate_config(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` (a config file's settings, sections nested) in the current schema, without
    its ``schema`` key; a schema this version does not know is a ``ValueError``."""
    values = dict(data)
    schema = _schema(values, CONFIG_SCHEMA, "config")
    values.pop(SCHEMA_KEY, None)
    if schema == 1:
        values = _config_1_to_2(values)
    if schema == 2:
        values = _config_2_to_3(values)
    return values


def _config_1_to_2(values: dict[str, Any]) -> dict[str, Any]:
    flat = {key: values.pop(key) for key in list(values) if key in FLAT_PPO_KEYS}
    if not flat:
        return values
    own = "dqn" if values.get("method") == "mac-dqn" else "ppo"
    for section in SCHEMA_1_SECTIONS:
        if section != own:
            values.pop(section, None)
    if own == "ppo":
        values["ppo"] = {**flat, **values.get("ppo", {})}
    return values


def _config_2_to_3(values: dict[str, Any]) -> dict[str, Any]:
    if isinstance(values.get("ppo"), dict):
        values["ppo"] = {**EXPLORATION_OFF, **values["ppo"]}
    return values


def migrate_checkpoint(state: dict[str, Any]) -> dict[str, Any]:
    """A loaded checkpoint's entries in the current schema (its config included, when it
    holds one), without the ``schema`` entry."""
    state = dict(state)
    schema = _schema(state, CHECKPOINT_SCHEMA, "checkpoint")
    state.pop(SCHEMA_KEY, None)
    config = state.get("config")
    if schema == 1:
        if "sampler" in state:
            state["envs"] = state.pop("sampler")
        if isinstance(config, dict):
            state["config"] = _config_1_to_2(dict(config))
    elif schema == 2 and isinstance(config, dict):
        state["config"] = _config_2_to_3(dict(config))
    return state


def _checksums_of_its_schema(state: dict[str, Any]) -> tuple[str | None, ...]:
    """The checksum entries a checkpoint of ``state``'s schema may carry (module docstring)."""
    from maopg.learner.checkpoint import CHECKSUM_KEY, TENSORS_CHECKSUM_KEY

    schema = state.get(SCHEMA_KEY, 1)
    if not isinstance(schema, int) or schema >= WHOLE_CHECKSUM_SCHEMA:  # a bad one: migrated,
        return (CHECKSUM_KEY,)  # it is refused by name
    return (CHECKSUM_KEY, TENSORS_CHECKSUM_KEY) + ((None,) if schema == 1 else ())


def read_checkpoint(path: str | os.PathLike[str], required: tuple[str, ...] = ()) -> dict:
    """A checkpoint file's entries, verified by the checksum its schema carries (module
    docstring), in the current schema (:func:`migrate_checkpoint`). (The learner, and torch,
    are imported here: the run's config files are read without them.)"""
    from maopg.learner import load_checkpoint

    return migrate_checkpoint(load_checkpoint(path, required, accepts=_checksums_of_its_schema))
