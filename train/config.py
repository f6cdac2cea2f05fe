"""The training configuration: one flat dataclass, resolved once, saved as JSON in the run dir.

Command-line ``key=value`` overrides address its fields by name (``epochs=5``,
``discount=option``); ``env.NAME=VALUE`` goes to the task's config overrides
(``env.max_ticks=100``). Fields left ``None`` take per-task defaults in :meth:`resolved`.
"""

from __future__ import annotations

import dataclasses
import json
import types
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Union, get_args, get_origin, get_type_hints

from maopg.learner import DiscountForm, EnvConfig, PPOConfig

METHODS: dict[str, tuple[str, str]] = {
    "async": ("continue", "centralized"),
    "sync-cut": ("any", "centralized"),
    "sync-wait": ("all", "centralized"),
    "end2end": ("primitive", "centralized"),
    "partial": ("continue", "partial"),
}
"""Method name → (termination strategy, policy kind), DESIGN §6."""

TASK_DEFAULTS: dict[str, dict[str, Any]] = {
    # The paper's batch sizes in low-level samples (TD 200, WF 2000); budgets cover its curves.
    "tool_delivery": {"batch_ticks": 200, "total_samples": 100_000, "images": False},
    "water_filling": {"batch_ticks": 2000, "total_samples": 200_000, "images": True},
}


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
    epochs: int = 10
    num_minibatches: int = 1
    clip: float = 0.2
    value_clip: float = 0.2
    huber_delta: float = 10.0
    ent_coef: float = 0.01
    value_coef: float = 1.0
    lr: float = 5e-4
    critic_lr: float = 5e-4
    adam_eps: float = 1e-5
    max_grad_norm: float = 10.0
    normalize_advantages: bool = True
    value_norm: bool = True
    hidden: int = 128
    """Width of the encoders' MLP layers (actor and critic)."""
    layers: int = 2
    """Depth of the encoders' MLPs."""

    checkpoint_every: int = 10
    """Iterations between checkpoints (one is also written at the end)."""
    torch_threads: int = 1
    """``torch.set_num_threads`` (0 = torch's default). One thread is fastest for the small
    state-vector networks and avoids oversubscribing the cores the environments use."""
    progress: bool = True
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
        if self.task not in TASK_DEFAULTS:
            raise ValueError(f"unknown task {self.task!r}; known: {sorted(TASK_DEFAULTS)}")
        DiscountForm(self.discount)
        defaults = TASK_DEFAULTS[self.task]
        cfg = dataclasses.replace(self, env_overrides=dict(self.env_overrides))
        for key in ("total_samples", "batch_ticks", "images"):
            if getattr(cfg, key) is None:
                setattr(cfg, key, defaults[key])
        if cfg.run_dir is None:
            cfg.run_dir = str(Path("runs") / cfg.task / cfg.method / f"seed{cfg.seed}")
        for key in ("total_samples", "batch_ticks", "num_envs", "epochs", "checkpoint_every"):
            if getattr(cfg, key) < 1:
                raise ValueError(f"{key} must be >= 1, got {getattr(cfg, key)}")
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

    @staticmethod
    def from_dict(data: dict[str, Any]) -> TrainConfig:
        names = {f.name for f in dataclasses.fields(TrainConfig)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(f"unknown config keys {unknown}")
        return TrainConfig(**data)

    def save(self, path: Path) -> None:
        path.write_text(json.dumps(self.to_dict(), indent=2, sort_keys=True) + "\n")

    @staticmethod
    def load(path: Path) -> TrainConfig:
        return TrainConfig.from_dict(json.loads(path.read_text()))


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


def parse_overrides(items: list[str]) -> dict[str, Any]:
    """``["epochs=5", "env.max_ticks=100"]`` → typed field values (``env.*`` under
    ``env_overrides``, parsed as JSON where possible, else kept as strings)."""
    hints = get_type_hints(TrainConfig)
    fields = {f.name for f in dataclasses.fields(TrainConfig)} - {"env_overrides"}
    values: dict[str, Any] = {}
    env: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep:
            raise ValueError(f"override {item!r} is not of the form key=value")
        if key.startswith("env."):
            try:
                env[key[4:]] = json.loads(text)
            except json.JSONDecodeError:
                env[key[4:]] = text
        elif key in fields:
            values[key] = _parse_value(text, hints[key], key)
        else:
            raise ValueError(f"unknown config key {key!r}; known: {sorted(fields)}")
    if env:
        values["env_overrides"] = env
    return values
