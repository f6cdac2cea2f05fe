"""The training configuration: one dataclass for every method, resolved once, saved as JSON in
the run directory.

The run's fields (task, seed, budget, observations, environments, network size, discount,
checkpoints) and the hyper-parameters of MAPPO — the paper's method, used by every method but
one — are top-level fields; the Mac-DQN baseline's own hyper-parameters form the ``dqn`` section
(:class:`~maopg.learner.macdqn.MacDQNConfig`). Command-line ``key=value`` overrides address
fields by name (``epochs=5``, ``discount=option``), ``dqn.NAME=VALUE`` the section
(``dqn.lr=1e-3``) and ``env.NAME=VALUE`` the task's config overrides (``env.max_ticks=100``).
Fields left ``None`` take per-task defaults in :meth:`TrainConfig.resolved`.
"""

from __future__ import annotations

import dataclasses
import json
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Union, get_args, get_origin, get_type_hints

from maopg.learner import DiscountForm, EnvConfig, MacDQNConfig, PPOConfig
from maopg.tasks import task_names

MAC_DQN = "mac-dqn"
JOINT_Q = "joint-q"
METHODS: dict[str, tuple[str, str]] = {
    "async": ("continue", "centralized"),
    "sync-cut": ("any", "centralized"),
    "sync-wait": ("all", "centralized"),
    "end2end": ("primitive", "centralized"),
    "partial": ("continue", "partial"),
    MAC_DQN: ("continue", JOINT_Q),
}
"""Method name → (termination strategy, policy kind), docs/DESIGN.md §6. MAPPO trains a conditional
``centralized`` or ``partial`` policy; Mac-DQN (``joint-q``) a joint Q-network whose policy is
the conditional argmax."""

SECTIONS: dict[str, type] = {"dqn": MacDQNConfig}
"""Nested config sections: name → dataclass (addressed as ``name.field=value``)."""

TASK_DEFAULTS: dict[str, dict[str, Any]] = {
    # The paper's batch sizes in low-level samples (TD 200, WF 2000); budgets cover its curves.
    "tool_delivery": {"batch_ticks": 200, "total_samples": 100_000, "images": False},
    "water_filling": {"batch_ticks": 2000, "total_samples": 200_000, "images": True},
}

GENERIC_DEFAULTS: dict[str, Any] = {"batch_ticks": 1000, "total_samples": 100_000, "images": False}
"""For a task registered by a user (``maopg.tasks.register_task``) with no entry above."""


@dataclass
class TrainConfig:
    """Everything a training run depends on. A resolved config fully determines the run."""

    task: str = "tool_delivery"
    method: str = "async"
    seed: int = 0
    total_samples: int | None = None
    """Low-level ticks to train for (per-task default)."""
    batch_ticks: int | None = None
    """Low-level ticks per iteration (paper: TD 200, WF 2000)."""
    images: bool | None = None
    """RGB camera observations (per-task default: WF yes, TD no)."""
    image_size: int = 64
    num_envs: int = 4
    num_workers: int = 0
    """Environment worker processes (``spawn``); 0 or 1 keeps environments in-process."""

    gamma: float = 0.99
    gae_lambda: float = 0.95
    discount: str = DiscountForm.SMDP.value
    """``smdp`` (γ^k per option step, default) or ``option`` (the paper's γ per option step)."""
    # MAPPO's hyper-parameters, flat so the CLI reads ``epochs=5``; defaults live in PPOConfig.
    epochs: int = PPOConfig.epochs
    num_minibatches: int = PPOConfig.num_minibatches
    clip: float = PPOConfig.clip
    value_clip: float = PPOConfig.value_clip
    huber_delta: float = PPOConfig.huber_delta
    ent_coef: float = PPOConfig.ent_coef
    value_coef: float = PPOConfig.value_coef
    lr: float = PPOConfig.lr
    critic_lr: float = PPOConfig.critic_lr
    adam_eps: float = PPOConfig.adam_eps
    max_grad_norm: float = PPOConfig.max_grad_norm
    normalize_advantages: bool = PPOConfig.normalize_advantages
    value_norm: bool = True
    hidden: int = 128
    """Width of the encoders' MLP layers (actor and critic)."""
    layers: int = 2
    """Depth of the encoders' MLPs."""

    dqn: MacDQNConfig = field(default_factory=MacDQNConfig)
    """Mac-DQN's hyper-parameters (``--method mac-dqn`` only)."""

    checkpoint_every: int = 10
    """Iterations between checkpoints (one is also written at the end)."""
    torch_threads: int = 1
    """``torch.set_num_threads`` (0 = torch's default). One thread is fastest for the small
    state-vector networks and avoids oversubscribing the cores the environments use."""
    progress: bool = True
    video: bool = True
    """Record a rollout of the trained policy (seed 0) to ``rollout.mp4`` at the end
    (~45 s on Water Filling; ``video=false`` skips it, as the reproduction grid does)."""
    video_sample: bool = True
    """Sample the video's options from the policy, as in training (Mac-DQN: ε-greedy at its
    final ε); ``false`` takes the greedy option. The greedy policy can loop where the stochastic
    one does not: on Water Filling always, on Tool Delivery after a short budget
    (results/README.md, Water Filling finding 6)."""
    run_dir: str | None = None
    """Default: ``runs/<task>/<method>/seed<seed>``."""
    env_overrides: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ derived views
    @property
    def strategy(self) -> str:
        return METHODS[self.method][0]

    @property
    def policy_kind(self) -> str:
        return METHODS[self.method][1]

    def resolved(self) -> TrainConfig:
        """A copy with every ``None`` replaced by its default, validated."""
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; known: {sorted(METHODS)}")
        if self.task not in task_names():
            raise ValueError(f"unknown task {self.task!r}; known: {task_names()}")
        DiscountForm(self.discount)
        defaults = TASK_DEFAULTS.get(self.task, GENERIC_DEFAULTS)
        cfg = dataclasses.replace(self, env_overrides=dict(self.env_overrides))
        for key in ("total_samples", "batch_ticks", "images"):
            if getattr(cfg, key) is None:
                setattr(cfg, key, defaults[key])
        if cfg.run_dir is None:
            cfg.run_dir = str(Path("runs") / cfg.task / cfg.method / f"seed{cfg.seed}")
        for key in ("total_samples", "batch_ticks", "num_envs", "epochs", "checkpoint_every"):
            if getattr(cfg, key) < 1:
                raise ValueError(f"{key} must be >= 1, got {getattr(cfg, key)}")
        cfg.dqn.validate()
        return cfg

    def ppo(self) -> PPOConfig:
        names = {f.name for f in dataclasses.fields(PPOConfig)}
        return PPOConfig(**{k: v for k, v in dataclasses.asdict(self).items() if k in names})

    def env(self) -> EnvConfig:
        return EnvConfig(
            task=self.task,
            strategy=self.strategy,
            images=bool(self.images),
            image_size=self.image_size,
            gamma=self.gamma,
            overrides=dict(self.env_overrides),
        )

    # ------------------------------------------------------------------ (de)serialisation
    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def flat(self) -> dict[str, Any]:
        """:meth:`to_dict` with section fields named as on the command line (``dqn.lr``)."""
        flat: dict[str, Any] = {}
        for key, value in self.to_dict().items():
            if key in SECTIONS:
                flat.update({f"{key}.{name}": v for name, v in value.items()})
            else:
                flat[key] = value
        return flat

    @staticmethod
    def from_dict(data: dict[str, Any]) -> TrainConfig:
        """Inverse of :meth:`to_dict`; a missing section (a config saved before it existed)
        takes its defaults."""
        values = dict(data)
        for name, section in SECTIONS.items():
            if isinstance(values.get(name), dict):
                values[name] = _build(section, values[name], f"{name}.")
        return _build(TrainConfig, values, "")

    def save(self, path: Path) -> None:
        path.write_text(json.dumps(self.to_dict(), indent=2, sort_keys=True) + "\n")

    @staticmethod
    def load(path: Path) -> TrainConfig:
        return TrainConfig.from_dict(json.loads(path.read_text()))


def _build(cls: type, data: dict[str, Any], prefix: str) -> Any:
    unknown = sorted(set(data) - {f.name for f in dataclasses.fields(cls)})
    if unknown:
        raise ValueError(f"unknown config keys {[prefix + k for k in unknown]}")
    return cls(**data)


def merge(base: dict[str, Any], values: dict[str, Any]) -> dict[str, Any]:
    """``base`` (a :meth:`TrainConfig.to_dict`) updated by ``values`` (from
    :func:`parse_overrides`); sections and ``env_overrides`` are updated key by key."""
    merged = dict(base)
    for key, value in values.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = {**merged[key], **value}
        else:
            merged[key] = value
    return merged


def _parse_value(text: str, annotation: Any, key: str) -> Any:
    """Parse ``text`` as the field type ``annotation`` (``int | None``, ``bool``, ...)."""
    options = get_args(annotation) if get_origin(annotation) in (Union, types.UnionType) else ()
    if options:
        if text.lower() in ("none", "null") and type(None) in options:
            return None
        annotation = next(t for t in options if t is not type(None))
    if annotation is bool:
        lowered = text.lower()
        if lowered in ("1", "true", "yes", "on"):
            return True
        if lowered in ("0", "false", "no", "off"):
            return False
        raise ValueError(f"{key}: expected a boolean, got {text!r}")
    try:
        if annotation is int:
            return int(text.replace("_", ""))
        if annotation is float:
            return float(text)
    except ValueError:
        raise ValueError(f"{key}: expected {annotation.__name__}, got {text!r}") from None
    return text


def split_assignment(item: str) -> tuple[str, str]:
    """``"key=value"`` → ``("key", "value")``; anything else is a :class:`ValueError`."""
    key, sep, text = item.partition("=")
    if not sep or not key:
        raise ValueError(f"{item!r} is not of the form key=value")
    return key, text


def parse_task_settings(items: list[str]) -> dict[str, Any]:
    """``["max_ticks=100", "turtlebot_robot=diffbot"]`` → task config overrides, values parsed
    as JSON where they are JSON (numbers, booleans, lists), else kept as strings."""
    settings: dict[str, Any] = {}
    for item in items:
        key, text = split_assignment(item)
        try:
            settings[key] = json.loads(text)
        except json.JSONDecodeError:
            settings[key] = text
    return settings


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """``["epochs=5", "dqn.lr=1e-3", "env.max_ticks=100"]`` → typed field values, sections as
    dicts (``{"epochs": 5, "dqn": {"lr": 0.001}, "env_overrides": {"max_ticks": 100}}``; task
    settings are parsed as JSON where possible, else kept as strings)."""
    values: dict[str, Any] = {}
    for item in items:
        key, text = split_assignment(item)
        section, dot, name = key.partition(".")
        if not dot:
            values[key] = _parse_field(TrainConfig, key, text, "")
        elif section == "env":
            values.setdefault("env_overrides", {}).update(parse_task_settings([f"{name}={text}"]))
        elif section in SECTIONS:
            values.setdefault(section, {})[name] = _parse_field(
                SECTIONS[section], name, text, f"{section}."
            )
        else:
            raise ValueError(f"unknown config section {section!r} in {item!r}")
    return values


def _parse_field(cls: type, name: str, text: str, prefix: str) -> Any:
    hints = get_type_hints(cls)
    fields = sorted(
        f.name
        for f in dataclasses.fields(cls)
        if f.name not in SECTIONS and f.name != "env_overrides"
    )
    if name not in fields:
        raise ValueError(f"unknown config key {prefix + name!r}; known: {fields}")
    return _parse_value(text, hints[name], prefix + name)
