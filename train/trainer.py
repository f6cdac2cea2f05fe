"""The training loop, readable top to bottom: each iteration collects a batch of low-level ticks
and learns from it, then logs and checkpoints; a killed run resumes from its last checkpoint.

One loop serves both learners; what an iteration does is the method's (:class:`MAPPORun`:
collect option steps, GAE, PPO update; :class:`MacDQNRun`: ε-greedy steps into the squeezed
replay with the Q-learning updates that fall due). Both count samples in low-level ticks, write
the same run directory and resume the same way.

Everything random flows from ``config.seed``: network initialisation (torch's global RNG),
acting (``sample_gen``), minibatches / replay sampling (``update_gen``) and the environments'
episode seeds (:func:`maopg.learner.episode_seed`). The checkpoint stores the generators' states
and each environment's (episode, options since reset), so a resumed run continues bit for bit.
"""

from __future__ import annotations

import math
import random
import shutil
import time
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from eval.policy import load_trained
from maopg.env.contract import EnvSpec
from maopg.learner import (
    MAPPO,
    MacDQN,
    Sampler,
    SqueezedReplay,
    ValueNorm,
    capture_global_rng,
    load_checkpoint,
    restore_global_rng,
    save_checkpoint,
)
from maopg.learner.buffer import Rollout
from maopg.learner.macdqn import point_arrays
from maopg.policy import CentralCritic, ObsBatch, build_policy, stack_conditions
from maopg.video import record_episode
from train.config import MAC_DQN, TrainConfig
from train.run_log import (
    CHECKPOINT,
    CONFIG,
    CURVE,
    DONE,
    FINAL,
    MACDQN_COLUMNS,
    MAPPO_COLUMNS,
    METRICS,
    VIDEO,
    RunLog,
    plot_learning_curve,
    read_done,
    write_done,
)

RESUMABLE_KEYS = ("total_samples", "progress", "video", "video_sample", "num_workers", "run_dir")
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
    saved = run_dir / CONFIG
    if resume and saved.exists():
        before, now = TrainConfig.load(saved).flat(), config.flat()
        clashes = {
            key: (value, now[key])
            for key, value in before.items()
            if key not in RESUMABLE_KEYS and value != now[key]
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


class MethodRun(ABC):
    """A method's part of the loop: its metrics columns, one iteration, and its state.

    Built once the sampler exists, from the environment's spec; it acts with ``sample_gen`` and
    draws minibatches or replay samples with ``update_gen``.
    """

    columns: tuple[str, ...]

    def __init__(
        self,
        config: TrainConfig,
        spec: EnvSpec,
        sample_gen: torch.Generator,
        update_gen: torch.Generator,
    ) -> None:
        self.config, self.sample_gen, self.update_gen = config, sample_gen, update_gen
        self.build(spec)

    @abstractmethod
    def build(self, spec: EnvSpec) -> None:
        """Create the networks (they draw from torch's global RNG, seeded before)."""

    @abstractmethod
    def iteration(self, sampler: Sampler, samples: int) -> tuple[dict[str, Any], int]:
        """Collect at least ``config.batch_ticks`` ticks (``samples`` so far) and learn;
        return the metrics row (without iteration, samples and timing) and the ticks taken."""

    @abstractmethod
    def final_state(self) -> dict[str, Any]:
        """What ``final.pt`` keeps to rebuild the policy (:func:`eval.policy.load_trained`)."""

    @abstractmethod
    def state_dict(self) -> dict[str, Any]:
        """Networks, optimisers and learner state for ``checkpoint.pt`` (top-level keys)."""

    @abstractmethod
    def load_state_dict(self, state: dict[str, Any]) -> None: ...


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else math.nan


def _episode_metrics(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """The shared columns about the episodes that ended in an iteration (NaN if none did)."""
    return {
        "episodes": len(episodes),
        "episode_return": _mean([e["return"] for e in episodes]),
        "episode_length": _mean([e["ticks"] for e in episodes]),
        "success_rate": _mean([e["solved"] for e in episodes]),
    }


def _iteration_metrics(
    rollout: Rollout,
    returns: np.ndarray,
    values: np.ndarray,
    stats: dict[str, float],
) -> dict[str, Any]:
    """What one MAPPO iteration reports (see :data:`train.run_log.MAPPO_COLUMNS`)."""
    variance = float(np.var(returns))
    explained = float(1.0 - np.var(returns - values) / variance) if variance > 1e-12 else math.nan
    return {
        "option_steps": rollout.num_steps * rollout.num_envs,
        **_episode_metrics(rollout.episodes),
        "option_step_reward": float(np.mean(rollout.grid("reward_sum"))),
        "explained_variance": explained,
        **stats,
    }


class MAPPORun(MethodRun):
    """MAPPO (every method but Mac-DQN): collect a rollout with the conditional policy, compute
    GAE over its option steps, run the PPO update."""

    columns = MAPPO_COLUMNS

    def build(self, spec: EnvSpec) -> None:
        config = self.config
        encoder = {"hidden": config.hidden, "layers": config.layers}
        self.policy = build_policy(config.policy_kind, spec, **encoder)  # type: ignore[arg-type]
        self.critic = CentralCritic(spec, **encoder)
        self.value_norm = ValueNorm() if config.value_norm else None
        self.learner = MAPPO(self.policy, self.critic, self.value_norm, config.ppo())

    def iteration(self, sampler: Sampler, samples: int) -> tuple[dict[str, Any], int]:
        cfg = self.config
        rollout = sampler.collect(
            self.policy, self.critic, batch_ticks=cfg.batch_ticks, generator=self.sample_gen
        )
        advantages, returns, values = rollout.advantages(
            self.value_norm, gamma=cfg.gamma, lam=cfg.gae_lambda, form=cfg.discount
        )
        stats = self.learner.update(rollout.training_batch(advantages, returns), self.update_gen)
        return _iteration_metrics(rollout, returns, values, stats), rollout.ticks

    def final_state(self) -> dict[str, Any]:
        return {
            "policy": self.policy.state_dict(),
            "critic": self.critic.state_dict(),
            "value_norm": {} if self.value_norm is None else self.value_norm.state_dict(),
        }

    def state_dict(self) -> dict[str, Any]:
        return {**self.final_state(), "optimizers": self.learner.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.policy.load_state_dict(state["policy"])
        self.critic.load_state_dict(state["critic"])
        if self.value_norm is not None:
            self.value_norm.load_state_dict(state["value_norm"])
        self.learner.load_state_dict(state["optimizers"])


class MacDQNRun(MethodRun):
    """Mac-DQN: step the environments with the ε-greedy conditional argmax, storing every
    decision point in the squeezed replay; a gradient step falls due every ``dqn.train_every``
    ticks from ``dqn.learning_starts`` on and the target network syncs every
    ``dqn.target_update_every`` ticks, so the x-axis (samples = ticks) means the same as for
    MAPPO."""

    columns = MACDQN_COLUMNS

    def build(self, spec: EnvSpec) -> None:
        config = self.config
        self.learner = MacDQN(
            spec,
            config.dqn,
            gamma=config.gamma,
            hidden=config.hidden,
            layers=config.layers,
            use_images=bool(config.images),
        )
        self.replay = SqueezedReplay(spec, config.dqn.buffer_size, config.num_envs)
        self.gru_state = self.learner.q.initial_state(config.num_envs)
        self.counters = {"slots": 0, "updates": 0, "syncs": 0}
        """Update slots passed, gradient steps taken, target syncs done."""

    def iteration(self, sampler: Sampler, samples: int) -> tuple[dict[str, Any], int]:
        dqn = self.config.dqn
        ticks, option_steps, rewards = 0, 0, []
        episodes: list[dict[str, Any]] = []
        stats: list[dict[str, float]] = []
        while ticks < self.config.batch_ticks:
            points = sampler.points
            joint, self.gru_state = self.learner.act(
                ObsBatch.from_decision_points(points),
                *stack_conditions(points),
                self.gru_state,
                dqn.epsilon(samples + ticks),
                self.sample_gen,
            )
            joints = joint.numpy()
            results = sampler.step(joints)
            for e, result in enumerate(results):
                outcome = result.outcome
                self.replay.add(e, point_arrays(points[e]), joints[e], outcome)
                rewards.append(outcome.reward)
                if result.final is not None:
                    episodes.append(dict(outcome.info["episode"]))
                    if self.gru_state is not None:
                        self.gru_state[:, e] = 0.0
            option_steps += len(results)
            ticks += sum(r.outcome.duration for r in results)
            stats += self._due_updates(samples + ticks)
        row = {
            "option_steps": option_steps,
            **_episode_metrics(episodes),
            "option_step_reward": _mean(rewards),
            "loss": _mean([s["loss"] for s in stats]),
            "q_mean": _mean([s["q_mean"] for s in stats]),
            "epsilon": dqn.epsilon(samples + ticks),
            "updates": self.counters["updates"],
        }
        return row, ticks

    def _due_updates(self, samples: int) -> list[dict[str, float]]:
        """Run the gradient steps and target syncs that the tick count has made due.

        Steps due while the replay cannot yet serve a batch (no finished episode) are skipped,
        not deferred.
        """
        dqn, counters = self.config.dqn, self.counters
        stats = []
        if samples >= dqn.learning_starts:
            due = (samples - dqn.learning_starts) // dqn.train_every + 1
            ready = bool(self.replay.episodes) if dqn.recurrent else len(self.replay) > 0
            while counters["slots"] < due:
                if ready:
                    stats.append(self.learner.update(self.replay, self.update_gen))
                    counters["updates"] += 1
                counters["slots"] += 1
        syncs = samples // dqn.target_update_every
        if syncs > counters["syncs"]:
            self.learner.sync_target()
            counters["syncs"] = syncs
        return stats

    def final_state(self) -> dict[str, Any]:
        return {"q": self.learner.q.state_dict()}

    def state_dict(self) -> dict[str, Any]:
        return {
            **self.learner.state_dict(),
            "replay": self.replay.state_dict(),
            "counters": dict(self.counters),
            "gru_state": torch.empty(0) if self.gru_state is None else self.gru_state,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.learner.load_state_dict(state)
        self.replay.load_state_dict(state["replay"])
        self.counters.update(state["counters"])
        if self.gru_state is not None:
            self.gru_state = state["gru_state"]


def train(config: TrainConfig, *, resume: bool = False, overwrite: bool = False) -> Path:
    """Train ``config`` (resolved here) and return the run directory."""
    config = _prepare_run_dir(config.resolved(), resume, overwrite)
    run_dir = Path(config.run_dir)  # type: ignore[arg-type]
    done = read_done(run_dir) if resume else None
    if done is not None:
        if done["samples"] >= config.total_samples:
            return run_dir  # finished: --resume has nothing to do (even with no checkpoint)
        # A larger budget: unfinished again until it is reached. The old weights go with the
        # marker, so a killed extension cannot pass its old policy off as the final one.
        (run_dir / DONE).unlink()
        for stale in (FINAL, VIDEO):
            (run_dir / stale).unlink(missing_ok=True)
    checkpoint_path = run_dir / CHECKPOINT
    resume = resume and checkpoint_path.exists()
    if config.torch_threads:
        torch.set_num_threads(config.torch_threads)
    sample_gen, update_gen = _seed_everything(config.seed)

    # Workers are spawned before this process builds anything that renders (docs/DESIGN.md §2).
    sampler = Sampler(
        config.env(), num_envs=config.num_envs, num_workers=config.num_workers, seed=config.seed
    )
    try:
        method = MacDQNRun if config.method == MAC_DQN else MAPPORun
        run: MethodRun = method(config, sampler.spec, sample_gen, update_gen)
        iteration, samples, wall_time = 0, 0, 0.0
        if resume:
            state = load_checkpoint(checkpoint_path, required=("iteration", "sampler"))
            run.load_state_dict(state)
            sample_gen.set_state(state["sample_gen"])
            update_gen.set_state(state["update_gen"])
            restore_global_rng(state["global_rng"])
            sampler.load_state_dict(state["sampler"])
            iteration, samples, wall_time = state["iteration"], state["samples"], state["wall_time"]
        else:
            sampler.reset()
        log = RunLog(run_dir, run.columns, resume_iteration=iteration if resume else None)

        def checkpoint() -> None:
            save_checkpoint(
                checkpoint_path,
                {
                    "config": config.to_dict(),
                    "iteration": iteration,
                    "samples": samples,
                    "wall_time": wall_time,
                    **run.state_dict(),
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
            row, ticks = run.iteration(sampler, samples)
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
            bar.update(min(ticks, config.total_samples - bar.n))
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
                **run.final_state(),
            },
        )
    finally:
        sampler.close()
    after_training(run_dir)
    write_done(run_dir, iterations=iteration, samples=samples, wall_time=wall_time)
    return run_dir


def after_training(run_dir: Path) -> None:
    """Artifacts of a finished run: the learning-curve plot and, with ``video``, a rollout of the
    trained policy (seed 0; sampled, or greedy with ``video_sample=false``) as ``rollout.mp4``.

    The policy is loaded back from ``final.pt`` the way ``python -m eval video`` loads it, so
    the video shows what the saved checkpoint does.
    """
    config = TrainConfig.load(run_dir / CONFIG)
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
