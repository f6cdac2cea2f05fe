"""The Mac-DQN training loop on the same environments, run directory and resume as ``train``.

One iteration collects ``batch_ticks`` low-level ticks from ``num_envs`` environments stepped in
lockstep (one decision point each per row, ε-greedy conditional argmax), storing every decision
point in the squeezed replay; a gradient step runs every ``train_every`` ticks once
``learning_starts`` ticks are in, and the target network is synced every
``target_update_every`` ticks. So the x-axis (samples = ticks) means the same as for MAPPO.

Run directory (as ``train``): ``config.json`` (the resolved config), ``metrics.csv`` (one row per
iteration, floats as ``repr``), ``tb/`` (TensorBoard), ``checkpoint.pt`` (atomic; networks,
optimizer, replay, the environments' episode logs, every RNG state), ``final.pt`` and
``learning_curve.png``. A killed run resumed from its checkpoint continues bit for bit.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import random
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from maopg.learner.checkpoint import (
    capture_global_rng,
    load_checkpoint,
    restore_global_rng,
    save_checkpoint,
)
from maopg.learner.macdqn import MacDQN, MacDQNConfig, SqueezedReplay, point_arrays
from maopg.learner.sampler import EnvConfig, Sampler, StepResult, episode_seed
from maopg.policy import ObsBatch, stack_conditions
from train.config import TASK_DEFAULTS
from train.run_log import plot_learning_curve, read_metrics
from train.trainer import CHECKPOINT, FINAL, RESUMABLE_KEYS

METHOD = "mac-dqn"

COLUMNS = (
    "iteration",
    "samples",
    "option_steps",
    "episodes",
    "episode_return",
    "episode_length",
    "success_rate",
    "option_step_reward",
    "loss",
    "q_mean",
    "epsilon",
    "updates",
    "samples_per_s",
    "wall_time",
)
"""Same meaning as ``train.run_log.COLUMNS`` where shared (``episode_return`` primary,
``option_step_reward`` the paper's metric); ``loss``/``q_mean`` average the iteration's updates
(NaN if none), ``epsilon`` is the exploration rate at the iteration's end, ``updates`` the total
number of gradient steps so far."""

_LEARNER_FIELDS = {f.name for f in dataclasses.fields(MacDQNConfig)}


@dataclass
class MacDQNTrainConfig:
    """A Mac-DQN run. Field names shared with ``train.config.TrainConfig`` mean the same."""

    task: str = "tool_delivery"
    method: str = METHOD
    seed: int = 0
    total_samples: int | None = None
    """Low-level ticks to train for (per-task default of ``train``)."""
    batch_ticks: int | None = None
    """Ticks per iteration (one metrics row); per-task default of ``train`` (TD 200)."""
    images: bool | None = None
    image_size: int = 64
    num_envs: int = 4
    """Environments stepped in lockstep (chosen here; MacDeepMARL TD used 1)."""
    num_workers: int = 0

    gamma: float = MacDQNConfig.gamma
    lr: float = MacDQNConfig.lr
    batch_size: int = MacDQNConfig.batch_size
    batch_episodes: int = MacDQNConfig.batch_episodes
    buffer_size: int = MacDQNConfig.buffer_size
    learning_starts: int = MacDQNConfig.learning_starts
    train_every: int = MacDQNConfig.train_every
    target_update_every: int = MacDQNConfig.target_update_every
    eps_start: float = MacDQNConfig.eps_start
    eps_end: float = MacDQNConfig.eps_end
    eps_decay: int = MacDQNConfig.eps_decay
    huber_delta: float = MacDQNConfig.huber_delta
    max_grad_norm: float = MacDQNConfig.max_grad_norm
    hidden: int = MacDQNConfig.hidden
    layers: int = MacDQNConfig.layers
    recurrent: bool = MacDQNConfig.recurrent
    """See :class:`maopg.learner.macdqn.MacDQNConfig` for each learner field and its source."""

    checkpoint_every: int = 10
    torch_threads: int = 0
    progress: bool = True
    run_dir: str | None = None
    """Default: ``runs/<task>/mac-dqn/seed<seed>``."""
    env_overrides: dict[str, Any] = field(default_factory=dict)

    def resolved(self) -> MacDQNTrainConfig:
        if self.method != METHOD:
            raise ValueError(f"a Mac-DQN config has method {METHOD!r}, got {self.method!r}")
        if self.task not in TASK_DEFAULTS:
            raise ValueError(f"unknown task {self.task!r}; known: {sorted(TASK_DEFAULTS)}")
        cfg = dataclasses.replace(self, env_overrides=dict(self.env_overrides))
        for key in ("total_samples", "batch_ticks", "images"):
            if getattr(cfg, key) is None:
                setattr(cfg, key, TASK_DEFAULTS[cfg.task][key])
        if cfg.run_dir is None:
            cfg.run_dir = str(Path("runs") / cfg.task / METHOD / f"seed{cfg.seed}")
        for key in ("total_samples", "batch_ticks", "num_envs", "checkpoint_every"):
            if getattr(cfg, key) < 1:
                raise ValueError(f"{key} must be >= 1, got {getattr(cfg, key)}")
        cfg.learner().validate()
        return cfg

    def learner(self) -> MacDQNConfig:
        return MacDQNConfig(**{k: v for k, v in self.to_dict().items() if k in _LEARNER_FIELDS})

    def env(self) -> EnvConfig:
        return EnvConfig(
            task=self.task,
            strategy="continue",
            images=bool(self.images),
            image_size=self.image_size,
            gamma=self.gamma,
            overrides=dict(self.env_overrides),
        )

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(data: dict[str, Any]) -> MacDQNTrainConfig:
        names = {f.name for f in dataclasses.fields(MacDQNTrainConfig)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(f"unknown Mac-DQN config keys {unknown}")
        return MacDQNTrainConfig(**data)

    def save(self, path: Path) -> None:
        path.write_text(json.dumps(self.to_dict(), indent=2, sort_keys=True) + "\n")

    @staticmethod
    def load(path: Path) -> MacDQNTrainConfig:
        return MacDQNTrainConfig.from_dict(json.loads(path.read_text()))


class _LockstepSampler(Sampler):
    """:class:`Sampler` (environments, episode seeds, replay-based resume) stepped one row at a
    time by an outside policy, keeping the same episode bookkeeping as ``Sampler.collect``."""

    def step(self, joints: np.ndarray) -> list[StepResult]:
        next_seeds = [episode_seed(self.seed, e, j + 1) for e, j in enumerate(self.episode)]
        results: list[StepResult] = self._envs.call_split("step", joints, next_seeds)
        for e, result in enumerate(results):
            if result.final is not None:
                self.episode[e] += 1
                self.actions[e] = []
            else:
                self.actions[e].append(joints[e].copy())
        self.points = [r.point for r in results]
        return results


def _format(value: Any) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    return str(value)


class _MetricsLog:
    """``metrics.csv`` + TensorBoard with :data:`COLUMNS`, following ``train.run_log.RunLog``:
    ``repr`` floats, and a resumed run first cuts the CSV back to its checkpoint's iteration."""

    def __init__(self, run_dir: Path, resume_iteration: int | None) -> None:
        from torch.utils.tensorboard import SummaryWriter

        self.path = run_dir / "metrics.csv"
        kept = []
        if resume_iteration is not None and self.path.exists():
            kept = [r for r in read_metrics(self.path) if int(r["iteration"]) <= resume_iteration]
        with self.path.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=COLUMNS)
            writer.writeheader()
            writer.writerows(kept)
        purge = None if resume_iteration is None else resume_iteration + 1
        self.tb = SummaryWriter(str(run_dir / "tb"), purge_step=purge)

    def write(self, row: dict[str, Any]) -> None:
        text = [_format(row[c]) for c in COLUMNS]
        with self.path.open("a", newline="") as handle:
            handle.write(",".join(text) + "\n")
        for key in COLUMNS[2:]:
            value = float(row[key])
            if not math.isnan(value):
                self.tb.add_scalar(f"train/{key}", value, int(row["samples"]))

    def close(self) -> None:
        self.tb.close()


def _prepare_run_dir(cfg: MacDQNTrainConfig, resume: bool, overwrite: bool) -> Path:
    """Create or reopen the run directory (the rules of ``train``: a resume must match the
    saved config except for :data:`train.trainer.RESUMABLE_KEYS`)."""
    run_dir = Path(cfg.run_dir)  # type: ignore[arg-type]
    saved = run_dir / "config.json"
    if resume and saved.exists():
        previous = MacDQNTrainConfig.load(saved).to_dict()
        clashes = [
            f"{k} (saved {v!r}, given {getattr(cfg, k)!r})"
            for k, v in previous.items()
            if k not in RESUMABLE_KEYS and v != getattr(cfg, k)
        ]
        if clashes:
            raise ValueError(f"--resume of {run_dir}: config differs in " + ", ".join(clashes))
    elif saved.exists() and not resume:
        if not overwrite:
            raise FileExistsError(
                f"run directory {run_dir} already holds a run; resume it, overwrite it, or "
                "choose another run directory"
            )
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    cfg.save(saved)
    return run_dir


def _seed(seed: int) -> tuple[torch.Generator, torch.Generator]:
    """Seed the global RNGs (network init); independent generators for acting and replay."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)
    act_seed, update_seed = np.random.SeedSequence([seed, 2]).generate_state(2)
    return (
        torch.Generator().manual_seed(int(act_seed)),
        torch.Generator().manual_seed(int(update_seed)),
    )


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else math.nan


def train_macdqn(
    cfg: MacDQNTrainConfig,
    run_dir: str | Path | None = None,
    resume: bool = False,
    overwrite: bool = False,
) -> dict[str, Any]:
    """Train Mac-DQN; ``run_dir`` (if given) replaces ``cfg.run_dir``. Returns a summary:
    ``run_dir``, ``iterations``, ``samples``, ``updates`` and ``last_returns`` (mean episode
    return of each iteration's finished episodes, NaN where none finished)."""
    if run_dir is not None:
        cfg = dataclasses.replace(cfg, run_dir=str(run_dir))
    cfg = cfg.resolved()
    path = _prepare_run_dir(cfg, resume, overwrite)
    checkpoint_path = path / CHECKPOINT
    resume = resume and checkpoint_path.exists()
    if cfg.torch_threads:
        torch.set_num_threads(cfg.torch_threads)
    act_gen, update_gen = _seed(cfg.seed)
    learner_cfg = cfg.learner()

    sampler = _LockstepSampler(
        cfg.env(), num_envs=cfg.num_envs, num_workers=cfg.num_workers, seed=cfg.seed
    )
    try:
        spec = sampler.spec
        learner = MacDQN(spec, learner_cfg, use_images=bool(cfg.images))
        replay = SqueezedReplay(spec, learner_cfg.buffer_size, cfg.num_envs)
        state = learner.q.initial_state(cfg.num_envs)
        counters = {"iteration": 0, "samples": 0, "slots": 0, "updates": 0, "syncs": 0}
        counters["wall_time"] = 0.0
        if resume:
            saved = load_checkpoint(checkpoint_path, required=("learner", "replay", "sampler"))
            learner.load_state_dict(saved["learner"])
            replay.load_state_dict(saved["replay"])
            act_gen.set_state(saved["act_gen"])
            update_gen.set_state(saved["update_gen"])
            restore_global_rng(saved["global_rng"])
            sampler.load_state_dict(saved["sampler"])
            counters.update(saved["counters"])
            if state is not None:
                state = saved["gru_state"]
        else:
            sampler.reset()
        log = _MetricsLog(path, counters["iteration"] if resume else None)

        def checkpoint() -> None:
            save_checkpoint(
                checkpoint_path,
                {
                    "config": cfg.to_dict(),
                    "counters": dict(counters),
                    "learner": learner.state_dict(),
                    "replay": replay.state_dict(),
                    "sampler": sampler.state_dict(),
                    "gru_state": torch.empty(0) if state is None else state,
                    "act_gen": act_gen.get_state(),
                    "update_gen": update_gen.get_state(),
                    "global_rng": capture_global_rng(),
                },
            )

        bar = tqdm(
            total=cfg.total_samples,
            initial=min(counters["samples"], cfg.total_samples),
            unit="tick",
            desc=f"{cfg.task}/{METHOD}/seed{cfg.seed}",
            disable=not cfg.progress,
            dynamic_ncols=True,
        )
        last_returns: list[float] = []
        while counters["samples"] < cfg.total_samples:
            start = time.perf_counter()
            ticks, option_steps, rewards = 0, 0, []
            episodes: list[dict[str, Any]] = []
            stats: list[dict[str, float]] = []
            while ticks < cfg.batch_ticks:
                points = sampler.points
                epsilon = learner_cfg.epsilon(counters["samples"])
                joint, state = learner.act(
                    ObsBatch.from_decision_points(points),
                    *stack_conditions(points),
                    state,
                    epsilon,
                    act_gen,
                )
                joints = joint.numpy()
                results = sampler.step(joints)
                for e, result in enumerate(results):
                    outcome = result.outcome
                    replay.add(e, point_arrays(points[e]), joints[e], outcome)
                    ticks += outcome.duration
                    rewards.append(outcome.reward)
                    if result.final is not None:
                        episodes.append(dict(outcome.info["episode"]))
                        if state is not None:
                            state[:, e] = 0.0
                option_steps += len(results)
                counters["samples"] += sum(r.outcome.duration for r in results)
                stats += _due_updates(learner, replay, counters, update_gen)
            elapsed = time.perf_counter() - start
            counters["iteration"] += 1
            counters["wall_time"] += elapsed
            episode_return = _mean([e["return"] for e in episodes])
            last_returns.append(episode_return)
            log.write(
                {
                    "iteration": counters["iteration"],
                    "samples": counters["samples"],
                    "option_steps": option_steps,
                    "episodes": len(episodes),
                    "episode_return": episode_return,
                    "episode_length": _mean([e["ticks"] for e in episodes]),
                    "success_rate": _mean([float(e["solved"]) for e in episodes]),
                    "option_step_reward": _mean(rewards),
                    "loss": _mean([s["loss"] for s in stats]),
                    "q_mean": _mean([s["q_mean"] for s in stats]),
                    "epsilon": learner_cfg.epsilon(counters["samples"]),
                    "updates": counters["updates"],
                    "samples_per_s": ticks / elapsed,
                    "wall_time": counters["wall_time"],
                }
            )
            bar.update(min(ticks, cfg.total_samples - bar.n))
            if episodes:
                bar.set_postfix(ret=f"{episode_return:.1f}", refresh=False)
            done = counters["samples"] >= cfg.total_samples
            if counters["iteration"] % cfg.checkpoint_every == 0 or done:
                checkpoint()
        bar.close()
        log.close()
        save_checkpoint(
            path / FINAL,
            {
                "config": cfg.to_dict(),
                "iteration": counters["iteration"],
                "samples": counters["samples"],
                "q_network": learner.q.state_dict(),
            },
        )
    finally:
        sampler.close()
    plot_learning_curve(path / "metrics.csv", path / "learning_curve.png")
    return {
        "run_dir": str(path),
        "iterations": counters["iteration"],
        "samples": counters["samples"],
        "updates": counters["updates"],
        "last_returns": last_returns,
    }


def _due_updates(
    learner: MacDQN,
    replay: SqueezedReplay,
    counters: dict[str, Any],
    generator: torch.Generator,
) -> list[dict[str, float]]:
    """Run the gradient steps and target syncs that the tick count has made due.

    Updates are due every ``train_every`` ticks from ``learning_starts`` on; steps due while the
    replay cannot yet serve a batch (no finished episode) are skipped, not deferred.
    """
    cfg = learner.config
    samples = counters["samples"]
    stats = []
    if samples >= cfg.learning_starts:
        due = (samples - cfg.learning_starts) // cfg.train_every + 1
        ready = bool(replay.episodes) if cfg.recurrent else len(replay) > 0
        while counters["slots"] < due:
            if ready:
                stats.append(learner.update(replay, generator))
                counters["updates"] += 1
            counters["slots"] += 1
    syncs = samples // cfg.target_update_every
    if syncs > counters["syncs"]:
        learner.sync_target()
        counters["syncs"] = syncs
    return stats


__all__ = ["COLUMNS", "METHOD", "MacDQNTrainConfig", "train_macdqn"]
