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
learner's finished-episode count, new with exploration, is 0 where absent). A checkpoint's
config is in its checkpoint's schema.

A command-line spelling of an earlier release (``epochs=5``, ``--set``) is not a saved file: the
command lines read it with one deprecation line
(:func:`maopg.experiment.run.config.parse_overrides`).
"""

from __future__ import annotations

from typing import Any

SCHEMA_KEY = "schema"
CONFIG_SCHEMA = 3
"""The layout :meth:`~maopg.experiment.run.config.TrainConfig.save` writes."""
CHECKPOINT_SCHEMA = 3
"""The layout the trainer's checkpoints are written in."""

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
