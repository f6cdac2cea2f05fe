"""The training loop, readable top to bottom: collect a batch of low-level ticks, compute GAE over
its option steps, run the PPO update, log, checkpoint; resume from the last checkpoint.

Everything random flows from ``config.seed``: network initialisation (torch's global RNG),
option sampling (``sample_gen``), minibatch order (``update_gen``) and the environments' episode
seeds (:func:`maopg.learner.episode_seed`). The checkpoint stores the generators' states and each
environment's (episode, options since reset), so a resumed run continues bit for bit.
"""

from __future__ import annotations

import math
import random
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from maopg.learner import (
    MAPPO,
    Sampler,
    ValueNorm,
    capture_global_rng,
    load_checkpoint,
    restore_global_rng,
    save_checkpoint,
)
from maopg.learner.buffer import Rollout
from maopg.policy import CentralCritic, OptionPolicy, build_policy
from train.config import TrainConfig
from train.run_log import RunLog, plot_learning_curve

CHECKPOINT = "checkpoint.pt"
FINAL = "final.pt"
RESUMABLE_KEYS = ("total_samples", "progress", "num_workers", "run_dir")
"""Config fields a resumed run may change: none of them changes what is computed."""


def _seed_everything(seed: int) -> tuple[torch.Generator, torch.Generator]:
    """Seed the global RNGs; return independent generators for sampling and minibatching."""
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)
    sample_seed, update_seed = np.random.SeedSequence([seed, 1]).generate_state(2)
    return (
        torch.Generator().manual_seed(int(sample_seed)),
        torch.Generator().manual_seed(int(update_seed)),
    )


def _prepare_run_dir(config: TrainConfig, resume: bool, overwrite: bool) -> TrainConfig:
    """Create or reopen the run directory; on resume the saved config wins (see RESUMABLE_KEYS)."""
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    saved = run_dir / "config.json"
    if resume and saved.exists():
        previous = TrainConfig.load(saved)
        clashes = {
            key: (getattr(previous, key), getattr(config, key))
            for key in previous.to_dict()
            if key not in RESUMABLE_KEYS and getattr(previous, key) != getattr(config, key)
        }
        if clashes:
            raise ValueError(
                f"--resume of {run_dir}: the config differs from the saved one in "
                + ", ".join(f"{k} (saved {a!r}, given {b!r})" for k, (a, b) in clashes.items())
            )
    elif saved.exists() and not resume:
        if not overwrite:
            raise FileExistsError(
                f"run directory {run_dir} already holds a run; pass --resume to continue it, "
                "--overwrite to start over, or choose another --run-dir"
            )
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    config.save(saved)
    return config


def _iteration_metrics(
    rollout: Rollout,
    returns: np.ndarray,
    values: np.ndarray,
    stats: dict[str, float],
) -> dict[str, Any]:
    """What one iteration reports (see :data:`train.run_log.COLUMNS`)."""
    episodes = rollout.episodes
    variance = float(np.var(returns))
    explained = float(1.0 - np.var(returns - values) / variance) if variance > 1e-12 else math.nan
    return {
        "option_steps": rollout.num_steps * rollout.num_envs,
        "episodes": len(episodes),
        "episode_return": float(np.mean([e["return"] for e in episodes])) if episodes else math.nan,
        "episode_length": float(np.mean([e["ticks"] for e in episodes])) if episodes else math.nan,
        "success_rate": float(np.mean([e["solved"] for e in episodes])) if episodes else math.nan,
        "option_step_reward": float(np.mean(rollout.grid("reward_sum"))),
        "explained_variance": explained,
        **stats,
    }


def train(config: TrainConfig, *, resume: bool = False, overwrite: bool = False) -> Path:
    """Train ``config`` (resolved here) and return the run directory."""
    config = _prepare_run_dir(config.resolved(), resume, overwrite)
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    checkpoint_path = run_dir / CHECKPOINT
    resume = resume and checkpoint_path.exists()
    if config.torch_threads:
        torch.set_num_threads(config.torch_threads)
    sample_gen, update_gen = _seed_everything(config.seed)

    # Workers are spawned before this process builds anything that renders (DESIGN §2).
    sampler = Sampler(
        config.env(), num_envs=config.num_envs, num_workers=config.num_workers, seed=config.seed
    )
    try:
        spec = sampler.spec
        encoder = {"hidden": config.hidden, "layers": config.layers}
        policy = build_policy(config.policy_kind, spec, **encoder)  # type: ignore[arg-type]
        critic = CentralCritic(spec, **encoder)
        value_norm = ValueNorm() if config.value_norm else None
        learner = MAPPO(policy, critic, value_norm, config.ppo())

        iteration, samples, wall_time = 0, 0, 0.0
        if resume:
            state = load_checkpoint(checkpoint_path, required=("policy", "sampler", "iteration"))
            policy.load_state_dict(state["policy"])
            critic.load_state_dict(state["critic"])
            if value_norm is not None:
                value_norm.load_state_dict(state["value_norm"])
            learner.load_state_dict(state["optimizers"])
            sample_gen.set_state(state["sample_gen"])
            update_gen.set_state(state["update_gen"])
            restore_global_rng(state["global_rng"])
            sampler.load_state_dict(state["sampler"])
            iteration, samples, wall_time = state["iteration"], state["samples"], state["wall_time"]
        else:
            sampler.reset()
        log = RunLog(run_dir, resume_iteration=iteration if resume else None)

        def checkpoint() -> None:
            save_checkpoint(
                checkpoint_path,
                {
                    "config": config.to_dict(),
                    "iteration": iteration,
                    "samples": samples,
                    "wall_time": wall_time,
                    "policy": policy.state_dict(),
                    "critic": critic.state_dict(),
                    "value_norm": {} if value_norm is None else value_norm.state_dict(),
                    "optimizers": learner.state_dict(),
                    "sample_gen": sample_gen.get_state(),
                    "update_gen": update_gen.get_state(),
                    "global_rng": capture_global_rng(),
                    "sampler": sampler.state_dict(),
                },
            )

        bar = tqdm(
            total=config.total_samples,
            initial=min(samples, config.total_samples),
            unit="tick",
            desc=f"{config.task}/{config.method}/seed{config.seed}",
            disable=not config.progress,
            dynamic_ncols=True,
        )
        while samples < config.total_samples:
            start = time.perf_counter()
            rollout = sampler.collect(
                policy, critic, batch_ticks=config.batch_ticks, generator=sample_gen
            )
            advantages, returns, values = rollout.advantages(
                value_norm, gamma=config.gamma, lam=config.gae_lambda, form=config.discount
            )
            stats = learner.update(rollout.training_batch(advantages, returns), update_gen)
            elapsed = time.perf_counter() - start
            iteration += 1
            samples += rollout.ticks
            wall_time += elapsed

            row = _iteration_metrics(rollout, returns, values, stats)
            row.update(
                iteration=iteration,
                samples=samples,
                samples_per_s=rollout.ticks / elapsed,
                wall_time=wall_time,
            )
            log.write(row)
            bar.update(min(rollout.ticks, config.total_samples - bar.n))
            if row["episodes"]:
                bar.set_postfix(ret=f"{row['episode_return']:.1f}", refresh=False)
            if iteration % config.checkpoint_every == 0 or samples >= config.total_samples:
                checkpoint()
        bar.close()
        log.close()
        save_checkpoint(
            run_dir / FINAL,
            {
                "config": config.to_dict(),
                "iteration": iteration,
                "samples": samples,
                "policy": policy.state_dict(),
                "critic": critic.state_dict(),
                "value_norm": {} if value_norm is None else value_norm.state_dict(),
            },
        )
    finally:
        sampler.close()
    after_training(run_dir, policy)
    return run_dir


def after_training(run_dir: Path, policy: OptionPolicy) -> None:
    """Artifacts of a finished run: the learning-curve plot, and the place for a rollout video.

    ``policy`` is the trained policy (also in ``final.pt``; the run's ``config.json`` says how to
    rebuild its environment). The evaluation tools plug their rollout video in here.
    """
    config = TrainConfig.load(run_dir / "config.json")
    title = f"{config.task} · {config.method} · seed {config.seed}"
    plot_learning_curve(run_dir / "metrics.csv", run_dir / "learning_curve.png", title)
