"""The training loop, readable top to bottom: each iteration the method's learner collects a
batch of low-level ticks and learns from it (``learner.iteration``; for MAPPO see
:meth:`maopg.learner.MAPPOLearner.iteration`), then the loop logs the row and checkpoints; a
killed run resumes from its last checkpoint.

Everything random flows from ``config.seed``: network initialisation (torch's global RNG),
acting (``sample_gen``), minibatches / replay sampling (``update_gen``) and the environments'
episode seeds (:func:`maopg.env.vector.episode_seed`). The checkpoint stores the generators'
states and each environment's (episode, options since reset), so a resumed run continues bit
for bit, whatever the backend. All of it is CPU state whatever ``config.device``: networks are
initialised on the CPU and moved, and the generators are CPU generators that draw on the CPU
(:class:`maopg.learner.LearnerSetup`), so ``device=cpu`` computes exactly what the code did
before it had a device, and a ``cuda`` run differs from it only by the GPU's rounding.
"""

from __future__ import annotations

import dataclasses
import random
import shutil
import time
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from maopg.env.ray_backend import RayOptions
from maopg.env.vector import SeededVectorEnv
from maopg.env.video import record_episode
from maopg.experiment.config import TrainConfig
from maopg.experiment.loading import load_trained
from maopg.experiment.methods import get_method
from maopg.experiment.run_dir import (
    CHECKPOINT,
    CONFIG,
    CURVE,
    DONE,
    FINAL,
    METRICS,
    VIDEO,
    RunLog,
    plot_learning_curve,
    read_done,
    write_done,
)
from maopg.learner import (
    CheckpointError,
    LearnerSetup,
    capture_global_rng,
    load_checkpoint,
    restore_global_rng,
    save_checkpoint,
)

RESUMABLE_KEYS = (
    "total_samples",
    "progress",
    "video",
    "video_sample",
    "plot",
    "backend",
    "num_workers",
    "run_dir",
    "plugins",
    *(f"ray.{f.name}" for f in dataclasses.fields(RayOptions)),
    "device",
)
"""Config fields a resumed run may change: none of them changes what is computed. ``device``
changes only how it is rounded: a run moved from ``cpu`` to ``cuda`` (or back) continues the
same updates on the same state (checkpoints hold CPU tensors, :mod:`maopg.learner.checkpoint`),
but its curve from there on is not bit-identical to an unmoved run's."""


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
    saved = run_dir / CONFIG
    if resume and saved.exists():
        # Resolved on this machine's device: the saved one may be a GPU this machine lacks, and
        # the device is resumable anyway.
        before = dataclasses.replace(TrainConfig.load(saved), device=config.device).resolved()
        before, now = before.flat(), config.flat()
        clashes = {
            key: (before.get(key), now.get(key))
            for key in sorted(set(before) | set(now))
            if key not in RESUMABLE_KEYS and before.get(key) != now.get(key)
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


def _envs_state(state: dict, path: Path) -> dict:
    """The environments' entry of a checkpoint (``sampler`` in checkpoints written before the
    vector environments had their own module)."""
    for key in ("envs", "sampler"):
        if key in state:
            return state[key]
    raise CheckpointError(f"checkpoint {path} lacks the entries ['envs']")


def train(config: TrainConfig, *, resume: bool = False, overwrite: bool = False) -> Path:
    """Train ``config`` (resolved here) and return the run directory."""
    config = _prepare_run_dir(config.resolved(), resume, overwrite)
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    done = read_done(run_dir) if resume else None
    if done is not None:
        if done["samples"] >= config.total_samples:
            return run_dir  # finished: --resume has nothing to do (even with no checkpoint)
        # A larger budget: unfinished again until it is reached. The old weights go with the
        # marker, so a killed extension cannot pass its old policy off as the final one (nor an
        # old curve: with plot=false none is drawn at the end).
        (run_dir / DONE).unlink()
        for stale in (FINAL, VIDEO, CURVE):
            (run_dir / stale).unlink(missing_ok=True)
    checkpoint_path = run_dir / CHECKPOINT
    resume = resume and checkpoint_path.exists()
    if config.torch_threads:
        torch.set_num_threads(config.torch_threads)
    sample_gen, update_gen = _seed_everything(config.seed)
    method = get_method(config.method)

    # Workers are spawned before this process builds anything that renders (docs/DESIGN.md §2).
    envs = SeededVectorEnv(
        config.env(),
        num_envs=config.num_envs,
        seed=config.seed,
        backend=config.backend,  # type: ignore[arg-type]
        num_workers=config.num_workers,
        backend_options=config.backend_options(),
    )
    try:
        size = {"hidden": config.hidden, "layers": config.layers}
        policy = method.build_policy(envs.spec, **size, config=config.learner)
        setup = LearnerSetup(
            spec=envs.spec,
            config=config.learner,
            num_envs=config.num_envs,
            batch_ticks=config.batch_ticks,  # type: ignore[arg-type]
            gamma=config.gamma,
            **size,
            sample_gen=sample_gen,
            update_gen=update_gen,
            device=torch.device(config.device),
        )
        learner = method.learner(policy, setup)
        iteration, samples, wall_time = 0, 0, 0.0
        if resume:
            state = load_checkpoint(checkpoint_path, required=("iteration",))
            learner.load_state_dict(state)
            sample_gen.set_state(state["sample_gen"])
            update_gen.set_state(state["update_gen"])
            restore_global_rng(state["global_rng"])
            envs.load_state_dict(_envs_state(state, checkpoint_path))
            iteration, samples, wall_time = state["iteration"], state["samples"], state["wall_time"]
        else:
            envs.reset()
        log = RunLog(run_dir, method.columns, resume_iteration=iteration if resume else None)

        def checkpoint() -> None:
            save_checkpoint(
                checkpoint_path,
                {
                    "config": config.to_dict(),
                    "iteration": iteration,
                    "samples": samples,
                    "wall_time": wall_time,
                    **learner.state_dict(),
                    "sample_gen": sample_gen.get_state(),
                    "update_gen": update_gen.get_state(),
                    "global_rng": capture_global_rng(),
                    "envs": envs.state_dict(),
                },
            )

        bar = tqdm(
            total=config.total_samples,
            initial=min(samples, config.total_samples),  # type: ignore[type-var]
            unit="tick",
            desc=f"{config.task}/{config.method}/seed{config.seed}",
            disable=not config.progress,
            dynamic_ncols=True,
        )
        while samples < config.total_samples:  # type: ignore[operator]
            start = time.perf_counter()
            row, ticks = learner.iteration(envs, samples)
            elapsed = time.perf_counter() - start
            iteration += 1
            samples += ticks
            wall_time += elapsed
            row.update(
                iteration=iteration,
                samples=samples,
                samples_per_s=ticks / elapsed,
                wall_time=wall_time,
            )
            log.write(row)
            bar.update(min(ticks, config.total_samples - bar.n))  # type: ignore[operator]
            if row["episodes"]:
                bar.set_postfix(ret=f"{row['episode_return']:.1f}", refresh=False)
            if iteration % config.checkpoint_every == 0 or samples >= config.total_samples:  # type: ignore[operator]
                checkpoint()
        bar.close()
        log.close()
        save_checkpoint(
            run_dir / FINAL,
            {
                "config": config.to_dict(),
                "iteration": iteration,
                "samples": samples,
                **learner.final_state(),
            },
        )
    finally:
        envs.close()
    after_training(run_dir)
    write_done(run_dir, iterations=iteration, samples=samples, wall_time=wall_time)
    return run_dir


def after_training(run_dir: Path) -> None:
    """Artifacts of a finished run: with ``plot``, the learning-curve plot and, with ``video``, a
    rollout of the trained policy (seed 0; sampled, or greedy with ``video_sample=false``) as
    ``rollout.mp4``.

    The policy is loaded back from ``final.pt`` the way ``python -m eval video`` loads it, so
    the video shows what the saved checkpoint does.
    """
    config = TrainConfig.load(run_dir / CONFIG)
    if config.plot:
        title = f"{config.task} · {config.method} · seed {config.seed}"
        plot_learning_curve(run_dir / METRICS, run_dir / CURVE, title)
    if config.video:
        trained = load_trained(run_dir / FINAL)
        env = trained.make_env(0)
        try:
            actor = trained.actor(greedy=not config.video_sample)
            record_episode(env, actor, run_dir / VIDEO, seed=0)
        finally:
            env.close()
