"""The training configuration: the run's fields plus its method's config section, resolved once
and saved as JSON in the run directory.

The run's fields (task, seed, budget, observations, environments, network size, discount,
checkpoints) are top-level; the learner's hyper-parameters form the section its method names
(``ppo`` for MAPPO, ``dqn`` for Mac-DQN, or a user learner's own). Command-line ``key=value``
overrides address fields by name (``num_envs=8``), ``SECTION.NAME=VALUE`` the section
(``ppo.epochs=5``, ``dqn.lr=1e-3``), ``env.NAME=VALUE`` the task's settings
(``env.max_ticks=100``), ``ray.NAME=VALUE`` the Ray backend's (``ray.address=auto``) and
``wandb.NAME=VALUE`` the W&B logger's (``wandb.project=mine``): :data:`RUN_SECTIONS`. Fields
left ``None`` take per-task defaults (declared by the task at registration) in
:meth:`TrainConfig.resolved`.

A config file (``--config run.yaml`` or ``.json``: :func:`read_config_file`) holds the same
keys, sections nested (``ppo: {epochs: 5}``, ``env: {max_ticks: 100}``) or dotted
(``ppo.epochs: 5``); a run's saved ``config.json`` is one. On a command line the file comes
first and ``key=value`` overrides it.

MAPPO's hyper-parameters used to be flat fields (``epochs=5``): on the command line the flat
keys stay accepted for one release, with a deprecation message; saved configs of any earlier
release are brought to today's layout when read (:mod:`maopg.experiment.run.migration`).
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import types
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Union, get_args, get_origin, get_type_hints

from maopg.env import OWN_ARGUMENTS, check_overrides
from maopg.env.ray_options import RayOptions, missing_ray, ray_available
from maopg.experiment.run.config_file import read_config_file
from maopg.experiment.run.methods import get_method, method_names, section_classes
from maopg.experiment.run.migration import CONFIG_SCHEMA, FLAT_PPO_KEYS, SCHEMA_KEY
from maopg.experiment.run.wandb_log import WandbOptions, missing_wandb, wandb_available
from maopg.policy.choices import PRECISION_NAMES
from maopg.settings import Settings, setting, unknown_setting
from maopg.sim.egl_check import gl_problem
from maopg.sim.looks import OFF, TRAINING
from maopg.tasks import make_config, task_class, task_entry
from maopg.tasks.config import MAX_IMAGE_SIZE, TaskConfig

if TYPE_CHECKING:
    from maopg.env.vector import EnvConfig

GENERIC_DEFAULTS: dict[str, Any] = {
    "batch_ticks": 1000,
    "total_samples": 100_000,
    "images": False,
    "backend": "threads",
}
"""For a task that declares no training defaults of its own (``register_task``)."""

WORKERS_PER_CORE = 2
"""The most worker processes per core that ``num_workers=0`` starts: enough for the operating
system to even out uneven steps (``bench/perf/lockstep.py``); each more holds its own MuJoCo models
and GL context, so 32 environments do not start 32 processes."""


DEVICES = ("auto", "cpu", "cuda")
"""The values of the ``device`` setting."""

LOGGERS = ("tensorboard", "wandb")
"""The values of the ``logger`` setting."""

RUN_SECTIONS: dict[str, type[Settings]] = {"ray": RayOptions, "wandb": WandbOptions}
"""Config sections of every run, whatever its method: where it runs and where it logs, never
what it computes (so a resumed run may change them)."""

NOT_RUN_FIELDS = ("env_overrides", "learner", *RUN_SECTIONS)
"""TrainConfig fields that are no ``key=value`` setting of their own."""


@dataclass
class TrainConfig(Settings):
    """Everything a training run depends on. A resolved config fully determines the run. Each
    field declares its kind and bounds (:mod:`maopg.settings`), checked when the config is made
    and again once :meth:`resolved` has filled in the defaults."""

    task: str = "tool_delivery"
    """The task trained on (``--task``): a registered task's name; its ``env.*`` settings are
    its own."""
    method: str = "async"
    """The method (``--method``): a registered method's name, which brings the termination
    strategy, the policy and the learner section it reads (``ppo``, ``dqn``, ...)."""
    seed: int = setting(0, ge=0)
    """Seeds every random stream of the run (episodes, initialisation, sampling)."""
    total_samples: int | None = setting(None, ge=1)
    """Low-level ticks to train for (per-task default)."""
    batch_ticks: int | None = setting(None, ge=1)
    """Low-level ticks per iteration (paper: TD 200, WF 2000)."""
    images: bool | None = None
    """RGB camera observations (per-task default: WF yes, TD no)."""
    image_size: int = setting(64, ge=1, le=MAX_IMAGE_SIZE)
    """Side of the square camera images (px)."""
    num_envs: int = setting(4, ge=1)
    """Environments stepped in lockstep, each playing its own seeded episodes."""
    backend: str | None = None
    """Where the environments run: ``local`` (this process, one after another), ``threads``
    (this process, stepped in parallel while ``mj_step`` and rendering release the GIL;
    ``bench/perf/backends.py`` measures the gain), ``processes`` (``spawn`` workers) or ``ray``
    (Ray actors, on this machine or a cluster: the ``ray.*`` settings); default
    ``processes`` when ``num_workers`` > 1, else the task's default: ``threads``, or
    ``processes`` for Water Filling, whose drone controller takes the GIL 25 times a tick
    (``bench/perf/backends.py``, ``bench/perf/lockstep.py``). All give the same rollouts."""
    num_workers: int = setting(0, ge=0)
    """Worker processes of the ``processes`` backend (0 = one per environment, at most
    :data:`WORKERS_PER_CORE` per core: the operating system then balances option steps of
    uneven length over the cores, where a worker stepping several environments in turn makes
    the others wait; ``bench/perf/lockstep.py``), actors of ``ray`` (0 = one), threads of
    ``threads`` (at least 2). At most ``num_envs``: a worker steps one environment at least."""
    ray: RayOptions = field(default_factory=RayOptions)
    """Where the ``ray`` backend's actors run (``ray.address=auto``; :class:`RayOptions`)."""
    logger: str = setting("tensorboard", choices=LOGGERS)
    """Where the per-iteration record goes besides ``metrics.csv``: ``tensorboard`` (always
    written) or ``wandb``, which mirrors it to Weights & Biases as well (the optional extra
    ``maopg[wandb]``; the ``wandb.*`` settings, :mod:`maopg.experiment.run.wandb_log`)."""
    wandb: WandbOptions = field(default_factory=WandbOptions)
    """The W&B project, entity, group and mode of ``logger=wandb`` (:class:`WandbOptions`)."""
    gamma: float = setting(0.99, ge=0.0, le=1.0)
    """Discount per tick (it also discounts the environment's rewards)."""
    hidden: int = setting(128, ge=1)
    """Width of the encoders' MLP layers (actor, critic, Q-network)."""
    layers: int = setting(2, ge=1)
    """Depth of the encoders' MLPs."""
    checkpoint_every: int = setting(10, ge=1)
    """Iterations between checkpoints (one is also written at the end)."""
    device: str = setting("auto", choices=DEVICES)
    """Where the networks, their optimisers and the updates run: ``cpu``, ``cuda`` or ``auto``
    (``cuda`` where ``torch.cuda.is_available()``, else ``cpu``); :meth:`resolved` replaces
    ``auto`` by the device it picked, so ``config.json`` records where the run computed. The
    environments always step (and render) on the CPU side. Bit-exact learning curves are
    promised on ``cpu`` only: CUDA kernels round differently (and not always deterministically),
    so a ``cuda`` run is reproducible in distribution, not bit for bit."""
    precision: str = setting("fp32", choices=PRECISION_NAMES)
    """What the image encoders (the CNNs) compute in: ``fp32``, or ``bf16``, faster on a CPU
    with bf16 instructions (AVX512-BF16, AMX) and ``torch_threads=1`` or on a recent GPU, slower
    elsewhere (``bench/perf/precision.py``; :func:`~maopg.policy.encoders.set_precision` says why
    only the CNNs). Deterministic on one machine either way, but a ``bf16`` run follows another
    trajectory than an ``fp32`` one. Runs without images compute the same in both."""
    torch_threads: int = setting(1, ge=0)
    """``torch.set_num_threads`` (0 = torch's default). One thread is fastest for the small
    state-vector networks and avoids oversubscribing the cores the environments use."""
    progress: bool = True
    """Show progress bars on stderr (training, and the evaluation and video at the end)."""
    video: bool = True
    """Record a rollout of the trained policy (seed 0) to ``rollout.mp4`` at the end
    (``video=false`` skips it, as the reproduction grid does; its cost is in
    ``bench/perf/video_speed.py``)."""
    video_gif: bool = False
    """Also put the rollout into TensorBoard (its IMAGES tab, tag ``rollout``) as an animated
    GIF: the MP4 read back frame by frame, shrunk and re-encoded
    (:mod:`maopg.experiment.run.tb_video`; its cost per frame is
    :data:`maopg.experiment.training.eta.GIF_SECONDS_PER_FRAME`), which grows the event file.
    Off by default: ``rollout.mp4`` beside the event file plays the same episode;
    ``video_gif=true`` (with ``video``) adds it."""
    plot: bool = True
    """Draw ``learning_curve.png`` at the end (~0.5-1 s, mostly importing matplotlib; ``false``
    skips it, as the tests' short runs do: ``python -m eval plot`` draws any run's curves later
    from its ``metrics.csv``)."""
    eval_episodes: int = setting(5, ge=0)
    """Seeded episodes the final policy plays at the end, greedy and sampled, for TensorBoard
    (``eval/return_greedy``, ``eval/return_sampled``, option choices per agent); 0 skips it, as
    the reproduction grid does (its ``evaluation.md`` evaluates every run's weights itself)."""
    eval_every: int = setting(0, ge=0)
    """Evaluation during training, the curve published results plot: after the iteration that
    reaches each multiple of this many samples, the policy plays ``eval_during_episodes``
    episodes in an environment of its own, and that row's ``eval_return``, ``eval_return_std``,
    ``eval_success`` and ``eval_length`` hold the outcome (``nan`` in the other rows). 0 (the
    default) evaluates nothing and writes no such column. The episodes and the draws come
    from seeds of their own (:func:`maopg.experiment.evaluation.evaluate.evaluation_seeds`), so the
    training columns are the same bit for bit with it on or off."""
    eval_during_episodes: int = setting(10, ge=1)
    """Episodes per evaluation during training (``eval_every``), each bounded at
    :data:`~maopg.experiment.evaluation.evaluate.EVAL_MAX_TICKS` ticks as the final evaluation's; 10
    as ACAC evaluates for its published curves."""
    eval_during_sample: bool = True
    """Evaluation during training samples its options from the policy, as published curves do
    (ACAC samples from its softmax; Mac-DQN: ε-greedy at its final ε); ``false`` takes the
    greedy option (Mac-DQN: ε 0)."""
    video_sample: bool = True
    """Sample the video's options from the policy, as in training (Mac-DQN: ε-greedy at its
    final ε); ``false`` takes the greedy option. The greedy policy can loop where the stochastic
    one does not: on Water Filling always, on Tool Delivery after a short budget
    (results/README.md, Water Filling finding 6)."""
    run_dir: str | None = None
    """Default: ``runs/<task>/<method>/seed<seed>``."""
    env_overrides: dict[str, Any] = field(default_factory=dict)
    plugins: list[str] = field(default_factory=list)
    """Modules imported before the run is built (``--import``, ``MAOPG_PLUGINS``): a resumed
    run and an evaluation of its checkpoint import them again (:mod:`maopg.plugins`)."""
    learner: Any = None
    """The method's config section (an instance of its learner's ``Config``; ``None`` = its
    defaults). Saved under the section's name (``"ppo": {...}``)."""

    def validate(self) -> None:
        from maopg.env.vector import BACKENDS  # the backends' registry: torch and MuJoCo

        super().validate()
        if self.backend is not None and self.backend not in BACKENDS:
            raise ValueError(f"backend must be one of {sorted(BACKENDS)}, got {self.backend!r}")
        check_overrides(self.env_overrides)

    # ------------------------------------------------------------------ derived views
    @property
    def strategy(self) -> str:
        return str(get_method(self.method).strategy)

    @property
    def section(self) -> str:
        return get_method(self.method).section

    def resolved(self) -> TrainConfig:
        """A copy with every ``None`` replaced by its default, validated (``ValueError``): the
        method's strategy among those its task runs under too."""
        method = get_method(self.method)
        defaults = {**GENERIC_DEFAULTS, **task_entry(self.task).train_defaults}
        cfg = dataclasses.replace(
            self, env_overrides=dict(self.env_overrides), plugins=list(self.plugins)
        )
        for key in ("total_samples", "batch_ticks", "images"):
            if getattr(cfg, key) is None:
                setattr(cfg, key, defaults[key])
        if cfg.backend is None:
            cfg.backend = "processes" if cfg.num_workers > 1 else defaults["backend"]
        if cfg.backend == "processes" and cfg.num_workers == 0:
            cfg.num_workers = min(cfg.num_envs, WORKERS_PER_CORE * (os.cpu_count() or 1))
        if cfg.num_workers > cfg.num_envs:
            raise ValueError(
                f"num_workers={cfg.num_workers} is more than num_envs={cfg.num_envs}: a worker "
                f"steps one environment at least, so num_workers may be 0 (the backend's "
                f"default) to {cfg.num_envs}"
            )
        if cfg.learner is None:
            cfg.learner = method.default_config(task_learner_defaults(cfg.task, method.section))
        elif not isinstance(cfg.learner, method.config_class):
            raise ValueError(
                f"method {cfg.method!r} takes a {method.config_class.__name__} section, "
                f"got {type(cfg.learner).__name__}"
            )
        if cfg.run_dir is None:
            cfg.run_dir = str(Path("runs") / cfg.task / cfg.method / f"seed{cfg.seed}")
        cfg.device = resolve_device(cfg.device)
        cfg.validate()
        if cfg.backend == "ray" and not ray_available():
            raise ValueError(missing_ray())
        if cfg.logger == "wandb" and not wandb_available():
            raise ValueError(missing_wandb())
        cfg.learner.validate()
        task_settings = make_config(cfg.task, cfg.env_overrides)  # names, kinds and bounds
        look = getattr(task_settings, "appearance", OFF)
        if look not in TRAINING:  # the held-out looks stay out of every training episode
            raise ValueError(
                f"env.appearance={look} is held out from training: a run trains under "
                f"{', '.join(TRAINING)}, and its policy is evaluated or filmed in {look} "
                f"(python -m eval evaluate --checkpoint RUN env.appearance={look})"
            )
        check_task = getattr(cfg.learner, "check_task", None)  # the section's relations to it
        if check_task is not None:
            check_task(task_settings)
        from maopg.tasks.base import require_strategy  # MuJoCo, which task_class loads anyway

        require_strategy(task_class(cfg.task), cfg.task, cfg.strategy, method=cfg.method)
        return cfg

    def rendering_problem(self) -> str | None:
        """Why this machine cannot render what the run renders (camera observations with
        ``images``, the final video with ``video``), or ``None``: the trainer asks before it
        writes anything, instead of failing at the first frame or after the whole run."""
        renders = [key for key in ("images", "video") if getattr(self, key)]
        problem = gl_problem() if renders else None
        return f"{problem} (this run renders: {renders[0]}=true)" if problem else None

    def backend_options(self) -> dict[str, Any]:
        """The chosen backend's own settings (the ``ray`` section for ``backend=ray``)."""
        return dataclasses.asdict(self.ray) if self.backend == "ray" else {}

    def env(self) -> EnvConfig:
        from maopg.env.vector import EnvConfig

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
        """JSON-ready: the run's fields and the section under its name."""
        values = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        section = values.pop("learner")
        if section is None:
            method = get_method(self.method)
            section = method.default_config(task_learner_defaults(self.task, method.section))
        values["env_overrides"] = dict(self.env_overrides)
        values["plugins"] = list(self.plugins)
        for name in RUN_SECTIONS:
            values[name] = dataclasses.asdict(getattr(self, name))
        values[self.section] = dataclasses.asdict(section)
        return values

    def flat(self) -> dict[str, Any]:
        """:meth:`to_dict` with section fields named as on the command line (``ppo.lr``)."""
        flat = self.to_dict()
        for name in (self.section, *RUN_SECTIONS):
            flat.update({f"{name}.{key}": v for key, v in flat.pop(name).items()})
        return flat

    @staticmethod
    def from_dict(data: dict[str, Any]) -> TrainConfig:
        """Inverse of :meth:`to_dict` (a config of an earlier release is brought to this
        layout when its file is read: :mod:`maopg.experiment.run.migration`). The method's section
        may be partial or missing: what it leaves unset takes the task's defaults for it, then
        the method's settings, then the learner's own (:meth:`Method.default_config`)."""
        values = dict(data)
        method = get_method(values.get("method", TrainConfig.method))
        own = method.section
        foreign = sorted(set(section_classes()) & set(values) - {own})
        if foreign:
            raise ValueError(
                f"config section(s) {foreign} do not belong to method {method.name!r} "
                f"(its section is {own!r})"
            )
        section = values.pop(own, None)
        run_sections = {name: values.pop(name, None) for name in RUN_SECTIONS}
        config = _build(TrainConfig, values, "")
        for name, given in run_sections.items():
            if given is not None:
                setattr(config, name, _build(RUN_SECTIONS[name], given, f"{name}."))
        given = section or {}
        _known(method.config_class, given, f"{own}.")
        config.learner = method.default_config(task_learner_defaults(config.task, own), **given)
        return config

    def save(self, path: Path) -> None:
        """As a ``config.json``: :meth:`to_dict` and the schema it is written in."""
        data = {SCHEMA_KEY: CONFIG_SCHEMA, **self.to_dict()}
        path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")

    @staticmethod
    def load(path: Path) -> TrainConfig:
        """A saved ``config.json`` (or any config file); every error names the file."""
        data = read_config_file(path)
        try:
            return TrainConfig.from_dict(data)
        except ValueError as err:
            raise ValueError(f"{path}: {err}") from None


def unset_run(method: str) -> dict[str, Any]:
    """The settings of a run of ``method`` that sets nothing (:meth:`TrainConfig.to_dict` of the
    defaults) without its learner section: what a command line or a grid merges its settings
    into. The section is left out, not written at its class defaults, so that the task's
    defaults for it (:func:`task_learner_defaults`) still apply to the keys nobody sets."""
    values = TrainConfig(method=method).to_dict()
    del values[get_method(method).section]
    return values


def task_learner_defaults(task: str, section: str) -> dict[str, Any]:
    """What ``task``'s training defaults set in the learner section ``section`` (its
    ``SECTION.KEY`` entries, by key): exploration on Box Pushing, say. A section of another
    learner is not this method's business (a ``ppo.*`` default leaves Mac-DQN alone)."""
    prefix = f"{section}."
    defaults = task_entry(task).train_defaults
    return {key[len(prefix) :]: value for key, value in defaults.items() if key.startswith(prefix)}


def resolve_device(device: str) -> str:
    """``auto`` → ``cuda`` if torch sees a GPU, else ``cpu``; ``cpu`` and ``cuda`` as given, but
    ``cuda`` without a GPU is a ``ValueError``, as is anything else (naming the setting)."""
    if device not in DEVICES:
        raise ValueError(f"device must be one of {list(DEVICES)}, got {device!r}")
    import torch  # only here: reading and checking a config needs no torch

    if device == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if device == "cuda" and not torch.cuda.is_available():
        raise ValueError(
            "device=cuda, but torch.cuda.is_available() is false on this machine "
            f"(torch {torch.__version__}); use device=cpu or device=auto"
        )
    return device


def _known(cls: type, data: dict[str, Any], prefix: str) -> None:
    """Every key of ``data`` names a field of ``cls`` (else a ``ValueError`` naming the first
    other and the nearest field)."""
    names = {f.name for f in dataclasses.fields(cls)} - {"learner", *RUN_SECTIONS}
    unknown = sorted(set(data) - names)
    if unknown:
        raise unknown_setting(prefix + unknown[0], [prefix + name for name in names])


def _build(cls: type, data: dict[str, Any], prefix: str) -> Any:
    _known(cls, data, prefix)
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
        raise ValueError(f"{key} expected bool, got {text!r}")
    try:
        if annotation is int:
            return int(text.replace("_", ""))
        if annotation is float:
            return float(text)
    except ValueError:
        raise ValueError(f"{key} expected {annotation.__name__}, got {text!r}") from None
    return text


def split_assignment(item: str) -> tuple[str, str]:
    """``"key=value"`` → ``("key", "value")``; anything else is a :class:`ValueError`."""
    key, sep, text = item.partition("=")
    if not sep or not key:
        raise ValueError(f"{item!r} is not of the form key=value")
    return key, text


def parse_task_settings(items: list[str]) -> dict[str, Any]:
    """``["max_ticks=100", "turtlebot_robot=diffbot"]`` → task config overrides, values parsed
    as JSON where they are JSON (numbers, booleans, lists), else kept as strings; ``inf`` and
    ``nan`` are the floats they spell, as for the run's own float fields, so a task setting
    refuses them as a non-finite number rather than as a string."""
    settings: dict[str, Any] = {}
    for item in items:
        key, text = split_assignment(item)
        if text.strip().lower().lstrip("+-") in ("inf", "infinity", "nan"):
            settings[key] = float(text)
            continue
        try:
            settings[key] = json.loads(text)
        except json.JSONDecodeError:
            settings[key] = text
    return settings


def parse_overrides(items: list[str], method: str) -> dict[str, Any]:
    """``["num_envs=8", "ppo.epochs=5", "env.max_ticks=100"]`` for a run of ``method`` → typed
    values for :func:`merge` (``{"num_envs": 8, "ppo": {"epochs": 5}, "env_overrides":
    {"max_ticks": 100}}``). The only section accepted is the method's own; a flat MAPPO key
    (``epochs=5``) is read as ``ppo.epochs=5`` with a deprecation message on stderr."""
    return _place_settings([split_assignment(item) for item in items], method, parse=True)


def nest_settings(settings: Mapping[str, Any], method: str) -> dict[str, Any]:
    """Typed settings under their command-line names (``{"ppo.epochs": 5, "env.max_ticks":
    100}``) for a run of ``method`` → values for :func:`merge`, placed as
    :func:`parse_overrides` places them (a study's settings: no text to read)."""
    return _place_settings(list(settings.items()), method, parse=False)


def _place_settings(pairs: list[tuple[str, Any]], method: str, *, parse: bool) -> dict[str, Any]:
    """Each ``(key, value)`` in the field, section or task setting its key names (``parse``:
    the value is command-line text, read as the field's type)."""
    own = get_method(method).section
    sections = section_classes()
    known = setting_names(method)
    values: dict[str, Any] = {}
    for key, given in pairs:
        item = f"{key}={given}"
        section, dot, name = key.partition(".")
        if not dot and key in FLAT_PPO_KEYS and key not in _run_fields():
            if own != "ppo":
                raise ValueError(f"{key!r} is a MAPPO hyper-parameter; method {method!r} has none")
            print(
                f"warning: {item} is deprecated and will be removed in the next release; "
                f"write ppo.{item}",
                file=sys.stderr,
            )
            section, name, dot = "ppo", key, "."
        if key == "strategy":
            raise ValueError(
                f"strategy is no setting: the method brings it; {methods_by_strategy()}"
            )
        if not dot:
            values[key] = _field_value(TrainConfig, key, given, "", parse, known)
        elif section == "env":
            setting = parse_task_settings([f"{name}={given}"])[name] if parse else given
            values.setdefault("env_overrides", {})[name] = setting
        elif section in RUN_SECTIONS:
            values.setdefault(section, {})[name] = _field_value(
                RUN_SECTIONS[section], name, given, f"{section}.", parse, known
            )
        elif section == own:
            values.setdefault(section, {})[name] = _field_value(
                sections[section], name, given, f"{section}.", parse, known
            )
        elif section in sections:
            raise ValueError(
                f"{item!r}: method {method!r} reads the {own!r} section, not {section!r}"
            )
        else:
            raise unknown_setting(key, known)
    return values


def _run_fields() -> list[str]:
    return sorted(f.name for f in dataclasses.fields(TrainConfig) if f.name not in NOT_RUN_FIELDS)


def methods_by_strategy() -> str:
    """``the strategies are continue (--method async, ...), any (--method sync-cut, ...)``."""
    by: dict[str, list[str]] = {}
    for name in method_names():
        by.setdefault(str(get_method(name).strategy), []).append(name)
    listed = ", ".join(
        f"{strategy} (--method {' / '.join(names)})" for strategy, names in by.items()
    )
    return f"the strategies are {listed}"


def setting_names(method: str) -> list[str]:
    """The settings a run of ``method`` takes as ``key=value`` whatever its task: the run's
    fields, its method's section, :data:`RUN_SECTIONS` and the task settings every task has
    (``env.max_ticks``), named as on the command line (``num_envs``, ``ppo.epochs``)."""
    own = get_method(method).section
    sections = {**RUN_SECTIONS, own: section_classes()[own], "env": TaskConfig}
    return _run_fields() + [
        f"{name}.{f.name}"
        for name, cls in sections.items()
        for f in dataclasses.fields(cls)
        if not (cls is TaskConfig and f.name in OWN_ARGUMENTS)
    ]


def _field_value(
    cls: type, name: str, given: Any, prefix: str, parse: bool, known: list[str]
) -> Any:
    """``given`` for field ``name`` of ``cls`` (an unknown name is an error naming the nearest
    of the ``known`` settings), read from command-line text where ``parse``."""
    hints = get_type_hints(cls)
    fields = (
        _run_fields() if cls is TrainConfig else sorted(f.name for f in dataclasses.fields(cls))
    )
    if name not in fields:
        raise unknown_setting(prefix + name, known)
    return _parse_value(given, hints[name], prefix + name) if parse else given
