"""Rollout collection from ``E`` option environments, in-process or in ``spawn`` worker processes.

Determinism. The learning curve must be a function of the run seed alone, whatever the number of
worker processes. So:

- environment ``e`` plays episode ``j`` from the seed :func:`episode_seed` ``(run seed, e, j)``;
- the policy samples in the main process, batched over all environments in environment order,
  with a ``torch.Generator`` the trainer owns (and checkpoints);
- environments are stepped in lockstep (one option step each per row) and results are gathered in
  environment order, whichever worker finishes first.

Resuming. An environment's state is the seed of its current episode plus the joint options taken
since that episode's reset: :meth:`Sampler.state_dict` stores exactly that, and
:meth:`Sampler.load_state_dict` replays it (at most one episode per environment), which rebuilds
the physics, the option executions and the observations bit for bit, since the simulation is
deterministic given seed and actions. A replay whose decision point differs from the recorded
one (fingerprint of observations, condition and tick count) raises instead of silently diverging.

Rendering. A ``fork``ed child hangs if its parent already created a MuJoCo renderer
(docs/DESIGN.md §2), so workers are ``spawn``ed and the main process never builds an environment
when workers are used: it asks worker 0 for the :class:`~maopg.env.contract.EnvSpec`.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import multiprocessing as mp
import traceback
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

import numpy as np
import torch

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.learner.buffer import Rollout
from maopg.policy import CentralCritic, ObsBatch, OptionPolicy, stack_conditions


def episode_seed(run_seed: int, env_index: int, episode: int) -> int:
    """The reset seed of episode ``episode`` of environment ``env_index`` in run ``run_seed``."""
    return int(np.random.SeedSequence([run_seed, env_index, episode]).generate_state(1)[0])


def _digest(point: DecisionPoint) -> str:
    """Fingerprint of a decision point's observations and condition (to verify a replay)."""
    digest = hashlib.sha256()
    for array in (*point.vectors, point.choosing, point.running, *point.available):
        digest.update(np.ascontiguousarray(array).tobytes())
    if point.images is not None:
        digest.update(np.ascontiguousarray(point.images).tobytes())
    digest.update(str(point.ticks).encode())
    return digest.hexdigest()


@dataclass(frozen=True)
class EnvConfig:
    """Everything needed to build one environment in any process (picklable)."""

    task: str
    strategy: str
    images: bool = False
    image_size: int = 64
    gamma: float = 0.99
    overrides: Mapping[str, Any] = field(default_factory=dict)

    def make(self, seed: int):
        from maopg.env import make_env

        return make_env(
            self.task,
            self.strategy,
            seed=seed,
            images=self.images,
            image_size=self.image_size,
            gamma=self.gamma,
            overrides=dict(self.overrides) or None,
        )


@dataclass
class StepResult:
    """One environment's answer to a step: the point to act on next, and the episode's final
    point when the step ended the episode (the environment has then already been reset)."""

    point: DecisionPoint
    final: DecisionPoint | None = None

    @property
    def outcome(self) -> DecisionPoint:
        """The point that reports this step's reward, duration and termination."""
        return self.final if self.final is not None else self.point


class LocalEnvs:
    """A group of environments living in this process (the body of one worker)."""

    def __init__(self, config: EnvConfig, env_indices: Sequence[int], run_seed: int) -> None:
        self.envs = [config.make(episode_seed(run_seed, e, 0)) for e in env_indices]

    def spec(self) -> EnvSpec:
        return self.envs[0].spec

    def reset(self, seeds: Sequence[int]) -> list[DecisionPoint]:
        return [copy.deepcopy(env.reset(seed=s)) for env, s in zip(self.envs, seeds, strict=True)]

    def step(self, joints: np.ndarray, next_seeds: Sequence[int]) -> list[StepResult]:
        """Step every environment; an episode that ends is reset with its ``next_seeds`` entry."""
        results = []
        for env, joint, seed in zip(self.envs, joints, next_seeds, strict=True):
            point = copy.deepcopy(env.step(joint))
            if point.done:
                results.append(StepResult(copy.deepcopy(env.reset(seed=seed)), point))
            else:
                results.append(StepResult(point))
        return results

    def replay(self, seeds: Sequence[int], actions: Sequence[np.ndarray]) -> list[DecisionPoint]:
        """Reset each environment with its seed and re-apply its recorded joint options."""
        points = []
        for env, seed, joints in zip(self.envs, seeds, actions, strict=True):
            point = env.reset(seed=seed)
            for joint in joints:
                point = env.step(joint)
                if point.done:
                    raise RuntimeError("replayed actions ended the episode: log is inconsistent")
            points.append(copy.deepcopy(point))
        return points

    def close(self) -> None:
        for env in self.envs:
            env.close()


def _worker(conn: Connection, config: EnvConfig, env_indices: list[int], run_seed: int) -> None:
    """Worker process loop: build the environments, then serve ``(method, args)`` requests."""
    import maopg  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

    envs = None
    try:
        envs = LocalEnvs(config, env_indices, run_seed)
        conn.send(("ok", None))
        while True:
            method, args = conn.recv()
            if method == "close":
                break
            conn.send(("ok", getattr(envs, method)(*args)))
    except (EOFError, KeyboardInterrupt):
        pass
    except Exception:
        conn.send(("error", traceback.format_exc()))
    finally:
        if envs is not None:
            envs.close()
        conn.close()


class _WorkerPool:
    """Environments split over ``spawn``ed processes; answers are merged in environment order."""

    def __init__(self, config: EnvConfig, num_envs: int, num_workers: int, run_seed: int):
        ctx = mp.get_context("spawn")
        self.groups = [list(g) for g in np.array_split(np.arange(num_envs), num_workers)]
        self.conns: list[Connection] = []
        self.procs = []
        for group in self.groups:
            parent, child = ctx.Pipe()
            proc = ctx.Process(
                target=_worker,
                args=(child, config, [int(e) for e in group], run_seed),
                daemon=True,
            )
            proc.start()
            child.close()
            self.conns.append(parent)
            self.procs.append(proc)
        for conn in self.conns:
            self._receive(conn)

    @staticmethod
    def _receive(conn: Connection) -> Any:
        try:
            status, payload = conn.recv()
        except EOFError as err:
            raise RuntimeError("an environment worker process died") from err
        if status == "error":
            raise RuntimeError(f"environment worker failed:\n{payload}")
        return payload

    def call_split(self, method: str, *per_env_args: Sequence[Any]) -> list[Any]:
        """Call ``method`` in every worker with its slice of each per-environment argument."""
        for conn, group in zip(self.conns, self.groups, strict=True):
            conn.send((method, tuple([arg[e] for e in group] for arg in per_env_args)))
        results: list[Any] = []
        for conn in self.conns:
            results.extend(self._receive(conn))
        return results

    def spec(self) -> EnvSpec:
        self.conns[0].send(("spec", ()))
        return self._receive(self.conns[0])

    def close(self) -> None:
        for conn, proc in zip(self.conns, self.procs, strict=True):
            with contextlib.suppress(BrokenPipeError, OSError):
                conn.send(("close", ()))
            proc.join(timeout=10)
            if proc.is_alive():
                proc.terminate()
            conn.close()


class _InProcess:
    """The same calls as :class:`_WorkerPool`, on environments in this process."""

    def __init__(self, config: EnvConfig, num_envs: int, run_seed: int) -> None:
        self.envs = LocalEnvs(config, range(num_envs), run_seed)

    def call_split(self, method: str, *per_env_args: Sequence[Any]) -> list[Any]:
        return getattr(self.envs, method)(*per_env_args)

    def spec(self) -> EnvSpec:
        return self.envs.spec()

    def close(self) -> None:
        self.envs.close()


class Sampler:
    """Collects option-level rollouts of a fixed number of low-level ticks.

    ``num_workers`` of 0 or 1 keeps the environments in this process; more spreads them over
    that many ``spawn`` processes (at most one per environment).
    """

    def __init__(self, config: EnvConfig, *, num_envs: int, num_workers: int, seed: int) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.num_envs = num_envs
        self.seed = seed
        workers = min(num_workers, num_envs)
        if workers > 1:
            self._envs: _WorkerPool | _InProcess = _WorkerPool(config, num_envs, workers, seed)
        else:
            self._envs = _InProcess(config, num_envs, seed)
        self.spec: EnvSpec = self._envs.spec()
        self.episode = [0] * num_envs
        self.actions: list[list[np.ndarray]] = [[] for _ in range(num_envs)]
        self.points: list[DecisionPoint] = []

    # ------------------------------------------------------------------ episodes and state
    def reset(self) -> None:
        """Start episode 0 of every environment."""
        self.episode = [0] * self.num_envs
        self.actions = [[] for _ in range(self.num_envs)]
        seeds = [episode_seed(self.seed, e, 0) for e in range(self.num_envs)]
        self.points = self._envs.call_split("reset", seeds)

    def state_dict(self) -> dict[str, Any]:
        """Episode counters and the joint options of each current episode (checkpoint-safe)."""
        n = self.spec.num_agents
        return {
            "episode": list(self.episode),
            "actions": [
                torch.from_numpy(np.asarray(a, dtype=np.int64).reshape(-1, n)) for a in self.actions
            ],
            "digest": [_digest(p) for p in self.points],
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Rebuild every environment's current episode by replaying its recorded options."""
        if len(state["episode"]) != self.num_envs:
            raise ValueError(
                f"state holds {len(state['episode'])} environments, sampler has {self.num_envs}"
            )
        self.episode = [int(j) for j in state["episode"]]
        self.actions = [list(a.numpy()) for a in state["actions"]]
        seeds = [episode_seed(self.seed, e, j) for e, j in enumerate(self.episode)]
        self.points = self._envs.call_split("replay", seeds, self.actions)
        got = [_digest(p) for p in self.points]
        if got != list(state["digest"]):
            bad = [e for e, (a, b) in enumerate(zip(got, state["digest"], strict=True)) if a != b]
            raise RuntimeError(
                f"replaying the saved options of environments {bad} did not reproduce their "
                "saved decision points: the environment is not deterministic given its seed "
                "and actions (or the task changed since the checkpoint)"
            )

    def close(self) -> None:
        self._envs.close()

    # ------------------------------------------------------------------ collection
    def step(self, joints: np.ndarray) -> list[StepResult]:
        """Apply one joint option per environment (``int64 [E, N]``), in lockstep.

        An environment whose episode ends is reset with its next episode seed at once; the
        result's ``final`` then holds the episode's last point. The returned points become
        :attr:`points`, and the options are logged for :meth:`state_dict`, so a learner that
        steps the environments itself (Mac-DQN) keeps the same seeds and exact resume.
        """
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

    @torch.no_grad()
    def collect(
        self,
        policy: OptionPolicy,
        critic: CentralCritic,
        *,
        batch_ticks: int,
        generator: torch.Generator,
    ) -> Rollout:
        """Step all environments in lockstep until ``batch_ticks`` ticks have been collected.

        The last row may overshoot ``batch_ticks`` by less than one option step per
        environment; :attr:`Rollout.ticks` is the exact count. Values are stored in the
        critic's own (normalised) space.
        """
        if not self.points:
            raise RuntimeError("call reset() or load_state_dict() before collect()")
        rollout = Rollout(num_envs=self.num_envs)
        obs = ObsBatch.from_decision_points(self.points)
        values = critic(obs)
        ticks = 0
        while ticks < batch_ticks:
            choosing, running, available = stack_conditions(self.points)
            dist = policy.distribution(obs, choosing, running, available)
            joint = dist.sample(generator)
            log_prob = dist.log_prob(joint)
            results = self.step(joint.numpy())
            outcomes = [r.outcome for r in results]
            next_obs = ObsBatch.from_decision_points(self.points)
            next_values = critic(next_obs)
            bootstrap = next_values.clone()
            truncated = [e for e, o in enumerate(outcomes) if o.truncated]
            if truncated:
                finals = ObsBatch.from_decision_points([outcomes[e] for e in truncated])
                bootstrap[truncated] = critic(finals)
            rollout.add(
                obs=obs,
                choosing=choosing,
                running=running,
                available=available,
                joint=joint,
                log_prob=log_prob,
                value=values,
                reward_sum=np.array([o.reward for o in outcomes]),
                reward_discounted=np.array([o.discounted_reward for o in outcomes]),
                duration=np.array([o.duration for o in outcomes]),
                terminated=np.array([o.terminated for o in outcomes]),
                truncated=np.array([o.truncated for o in outcomes]),
                next_value=bootstrap,
            )
            rollout.episodes += [
                dict(r.final.info["episode"]) for r in results if r.final is not None
            ]
            ticks += int(sum(o.duration for o in outcomes))
            obs, values = next_obs, next_values
        return rollout
