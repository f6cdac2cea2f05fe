"""Vector environments: ``E`` option environments stepped in lockstep, behind one interface.

A :class:`VectorEnv` backend only builds and steps environments; the backends differ in where
the environments live (:class:`LocalVectorEnv`: this process; :class:`ThreadVectorEnv`: this
process, on threads; :class:`ProcessVectorEnv`: ``spawn`` worker processes), chosen by name
through :data:`BACKENDS`, so a distributed backend is one more implementation
(:func:`register_backend`). Everything that decides *what* is simulated
stays in the main process, in :class:`SeededVectorEnv`, whatever the backend:

- environment ``e`` plays episode ``j`` from the seed :func:`episode_seed` ``(run seed, e, j)``;
- results are gathered in environment order, whichever worker finishes first;
- the joint options of each current episode are logged, so a checkpoint can rebuild every
  environment by *replaying* them (:meth:`SeededVectorEnv.load_state_dict`): the simulation is
  deterministic given seed and actions, so physics, option executions and observations come
  back bit for bit. A replay whose decision point differs from the recorded one (fingerprint of
  observations, condition and tick count) raises instead of silently diverging.

So the learning curve is a function of the run seed alone, for any backend and worker count.

Rendering. A ``fork``ed child hangs if its parent already created a MuJoCo renderer
(docs/DESIGN.md §2), so workers are ``spawn``ed and the main process never builds an environment
when workers are used: it asks worker 0 for the :class:`~maopg.env.contract.EnvSpec`.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import hashlib
import multiprocessing as mp
import pickle
import traceback
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any, Protocol

import numpy as np
import torch

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.env.option_env import OptionEnv
from maopg.plugins import load_plugins
from maopg.sim.robots import RobotSpec, get_robot, register_robot, robot_names
from maopg.tasks.registry import register_task, task_entry, task_names


def episode_seed(run_seed: int, env_index: int, episode: int) -> int:
    """The reset seed of episode ``episode`` of environment ``env_index`` in run ``run_seed``."""
    return int(np.random.SeedSequence([run_seed, env_index, episode]).generate_state(1)[0])


@dataclass(frozen=True)
class EnvConfig:
    """Everything needed to build one environment in any process (picklable)."""

    task: str
    strategy: str
    images: bool = False
    image_size: int = 64
    gamma: float = 0.99
    overrides: Mapping[str, Any] = field(default_factory=dict)

    def make(self, seed: int) -> OptionEnv:
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


class VectorEnv(Protocol):
    """What a backend does for :class:`SeededVectorEnv`; every list is in environment order."""

    num_envs: int

    def spec(self) -> EnvSpec: ...

    def reset(self, seeds: Sequence[int]) -> list[DecisionPoint]:
        """Reset environment ``e`` with ``seeds[e]``."""
        ...

    def step(self, joints: np.ndarray, next_seeds: Sequence[int]) -> list[StepResult]:
        """Apply ``joints[e]``; an episode that ends is reset at once with ``next_seeds[e]``."""
        ...

    def replay(
        self, seeds: Sequence[int], actions: Sequence[Sequence[np.ndarray]]
    ) -> list[DecisionPoint]:
        """Reset environment ``e`` with ``seeds[e]`` and re-apply its joint options."""
        ...

    def close(self) -> None: ...


class LocalVectorEnv:
    """Environments in this process (also the body of each worker of the process backend)."""

    def __init__(self, config: EnvConfig, env_indices: Sequence[int], run_seed: int) -> None:
        self.envs = [config.make(episode_seed(run_seed, e, 0)) for e in env_indices]
        self.num_envs = len(self.envs)

    def spec(self) -> EnvSpec:
        return self.envs[0].spec

    def reset(self, seeds: Sequence[int]) -> list[DecisionPoint]:
        return [copy.deepcopy(env.reset(seed=s)) for env, s in zip(self.envs, seeds, strict=True)]

    def step(self, joints: np.ndarray, next_seeds: Sequence[int]) -> list[StepResult]:
        results = []
        for env, joint, seed in zip(self.envs, joints, next_seeds, strict=True):
            point = copy.deepcopy(env.step(joint))
            if point.done:
                results.append(StepResult(copy.deepcopy(env.reset(seed=seed)), point))
            else:
                results.append(StepResult(point))
        return results

    def replay(
        self, seeds: Sequence[int], actions: Sequence[Sequence[np.ndarray]]
    ) -> list[DecisionPoint]:
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


class _SplitVectorEnv(ABC):
    """A backend that serves every call by giving each of its groups of environments its slice
    of the per-environment arguments (:meth:`_split`) and concatenating the answers."""

    @abstractmethod
    def _split(self, call: str, *per_env_args: Sequence[Any]) -> list[Any]:
        """``LocalVectorEnv.<call>`` on every group with its slices, answers in env order."""

    def reset(self, seeds: Sequence[int]) -> list[DecisionPoint]:
        return self._split("reset", seeds)

    def step(self, joints: np.ndarray, next_seeds: Sequence[int]) -> list[StepResult]:
        return self._split("step", joints, next_seeds)

    def replay(
        self, seeds: Sequence[int], actions: Sequence[Sequence[np.ndarray]]
    ) -> list[DecisionPoint]:
        return self._split("replay", seeds, actions)


class ThreadVectorEnv(_SplitVectorEnv):
    """Environments in this process, stepped in parallel on ``num_threads`` threads.

    ``mj_step`` releases the GIL, so physics of different environments overlaps while Python
    option logic interleaves. Environment ``e`` always runs on thread ``e % num_threads``: a
    camera's GL context may be current on one thread only, so each environment keeps the
    thread it rendered on first. Every environment is stepped exactly as in
    :class:`LocalVectorEnv` and results are gathered in environment order, so the rollouts are
    bit-identical to the ``local`` backend's.
    """

    def __init__(
        self, config: EnvConfig, num_envs: int, run_seed: int, *, num_threads: int = 2
    ) -> None:
        if num_threads < 1:
            raise ValueError(f"num_workers (threads) must be >= 1, got {num_threads}")
        self.num_envs = num_envs
        self.groups = [
            [int(e) for e in g]
            for g in np.array_split(np.arange(num_envs), min(num_threads, num_envs))
        ]
        self.pools = [
            ThreadPoolExecutor(1, thread_name_prefix=f"maopg-env{k}")
            for k in range(len(self.groups))
        ]
        self.envs = self._each(lambda group: LocalVectorEnv(config, group, run_seed), self.groups)

    def _each(self, call: Callable[..., Any], *per_group: Sequence[Any]) -> list[Any]:
        """``call(*args of group k)`` on group ``k``'s thread, for every group, in order."""
        futures = [
            pool.submit(call, *args) for pool, *args in zip(self.pools, *per_group, strict=True)
        ]
        return [f.result() for f in futures]

    def _split(self, call: str, *per_env_args: Sequence[Any]) -> list[Any]:
        sliced = [[[arg[e] for e in group] for arg in per_env_args] for group in self.groups]
        results = self._each(lambda envs, args: getattr(envs, call)(*args), self.envs, sliced)
        return [item for group in results for item in group]

    def spec(self) -> EnvSpec:
        return self.envs[0].spec()

    def close(self) -> None:
        self._each(lambda envs: envs.close(), self.envs)
        for pool in self.pools:
            pool.shutdown()


_CALLS = ("spec", "reset", "step", "replay")
"""The :class:`LocalVectorEnv` methods a worker serves."""


def _registrations(task: str) -> bytes:
    """What a worker needs of the parent's registries, pickled: classes travel by module and
    name, so the worker unpickles them only after importing its plugins (a plugin loaded from
    a file is a module only once imported). An entry that does not pickle (a lambda) is left
    out: the worker then relies on the plugins alone."""
    entry = task_entry(task)
    fields = {f.name: getattr(entry, f.name) for f in dataclasses.fields(entry)}
    fields = {k: dict(v) if isinstance(v, Mapping) else v for k, v in fields.items()}
    picklable = []
    for item in (fields, *(get_robot(name) for name in robot_names())):
        try:
            picklable.append(pickle.dumps(item))
        except (pickle.PicklingError, AttributeError, TypeError):
            continue
    return pickle.dumps(picklable)


def _adopt(registrations: bytes) -> None:
    """Register in this (spawned) process what the parent registered and this one lacks."""
    for item in map(pickle.loads, pickle.loads(registrations)):
        if isinstance(item, RobotSpec):
            if item.name not in robot_names():
                register_robot(item.name, item.mjcf, item.adapter, item.constants)
        elif item["name"] not in task_names():
            register_task(**item)


def _worker(
    conn: Connection,
    config: EnvConfig,
    env_indices: list[int],
    run_seed: int,
    registrations: bytes,
) -> None:
    """Worker process loop: build the environments, then serve ``(call, args)`` requests."""
    import maopg  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)

    envs = None
    try:
        # The parent's plugins (inherited MAOPG_PLUGINS), then whatever else it registered.
        load_plugins()
        _adopt(registrations)
        envs = LocalVectorEnv(config, env_indices, run_seed)
        conn.send(("ok", None))
        while True:
            call, args = conn.recv()
            if call == "close":
                break
            if call not in _CALLS:
                raise ValueError(f"unknown worker call {call!r}")
            conn.send(("ok", getattr(envs, call)(*args)))
    except (EOFError, KeyboardInterrupt):
        pass
    except Exception:
        conn.send(("error", traceback.format_exc()))
    finally:
        if envs is not None:
            envs.close()
        conn.close()


class ProcessVectorEnv(_SplitVectorEnv):
    """Environments split over ``num_workers`` ``spawn``ed processes (at most one per env)."""

    def __init__(
        self, config: EnvConfig, num_envs: int, run_seed: int, *, num_workers: int = 2
    ) -> None:
        if num_workers < 1:
            raise ValueError(f"num_workers must be >= 1, got {num_workers}")
        ctx = mp.get_context("spawn")
        self.num_envs = num_envs
        groups = np.array_split(np.arange(num_envs), min(num_workers, num_envs))
        self.groups = [[int(e) for e in g] for g in groups]
        registrations = _registrations(config.task)
        self.conns: list[Connection] = []
        self.procs = []
        for group in self.groups:
            parent, child = ctx.Pipe()
            args = (child, config, group, run_seed, registrations)
            proc = ctx.Process(target=_worker, args=args, daemon=True)
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

    def _split(self, call: str, *per_env_args: Sequence[Any]) -> list[Any]:
        """``call`` in every worker with its slice of each per-environment argument."""
        for conn, group in zip(self.conns, self.groups, strict=True):
            conn.send((call, tuple([arg[e] for e in group] for arg in per_env_args)))
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


BackendFactory = Callable[[EnvConfig, int, int, int], VectorEnv]
"""``factory(config, num_envs, run_seed, num_workers)`` → a :class:`VectorEnv`."""

BACKENDS: dict[str, BackendFactory] = {}
"""Backend name → factory: the values of the ``backend=`` config key."""


def register_backend(name: str, factory: BackendFactory, *, overwrite: bool = False) -> None:
    """Make ``backend=name`` build environments with ``factory`` (a distributed backend, say)."""
    if name in BACKENDS and not overwrite:
        raise ValueError(f"backend {name!r} is already registered (pass overwrite=True)")
    BACKENDS[name] = factory


register_backend("local", lambda config, n, seed, workers: LocalVectorEnv(config, range(n), seed))
register_backend(
    "threads",
    lambda config, n, seed, workers: ThreadVectorEnv(config, n, seed, num_threads=max(workers, 2)),
)
register_backend(
    "processes",
    lambda config, n, seed, workers: ProcessVectorEnv(config, n, seed, num_workers=workers),
)


def _digest(point: DecisionPoint) -> str:
    """Fingerprint of a decision point's observations and condition (to verify a replay)."""
    digest = hashlib.sha256()
    for array in (*point.vectors, point.choosing, point.running, *point.available):
        digest.update(np.ascontiguousarray(array).tobytes())
    if point.images is not None:
        digest.update(np.ascontiguousarray(point.images).tobytes())
    digest.update(str(point.ticks).encode())
    return digest.hexdigest()


class SeededVectorEnv:
    """A backend plus the main-process bookkeeping that makes a run reproducible and resumable
    (see the module docstring): episode seeds, the current points and the options since reset.

    Learners drive it with :meth:`step`; it knows nothing of any learning algorithm.
    """

    def __init__(
        self,
        config: EnvConfig,
        *,
        num_envs: int,
        seed: int,
        backend: str = "local",
        num_workers: int = 0,
    ) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        if backend not in BACKENDS:
            raise ValueError(f"unknown backend {backend!r}; known: {sorted(BACKENDS)}")
        self.num_envs = num_envs
        self.seed = seed
        self.backend: VectorEnv = BACKENDS[backend](config, num_envs, seed, num_workers)
        self.spec: EnvSpec = self.backend.spec()
        self.episode = [0] * num_envs
        self.actions: list[list[np.ndarray]] = [[] for _ in range(num_envs)]
        self.points: list[DecisionPoint] = []

    def reset(self) -> None:
        """Start episode 0 of every environment."""
        self.episode = [0] * self.num_envs
        self.actions = [[] for _ in range(self.num_envs)]
        self.points = self.backend.reset(
            [episode_seed(self.seed, e, 0) for e in range(self.num_envs)]
        )

    def step(self, joints: np.ndarray) -> list[StepResult]:
        """Apply one joint option per environment (``int64 [E, N]``), in lockstep.

        An environment whose episode ends is reset with its next episode seed at once; the
        result's ``final`` then holds the episode's last point. The returned points become
        :attr:`points`, and the options are logged for :meth:`state_dict`.
        """
        if not self.points:
            raise RuntimeError("call reset() or load_state_dict() before step()")
        next_seeds = [episode_seed(self.seed, e, j + 1) for e, j in enumerate(self.episode)]
        results = self.backend.step(joints, next_seeds)
        for e, result in enumerate(results):
            if result.final is not None:
                self.episode[e] += 1
                self.actions[e] = []
            else:
                self.actions[e].append(joints[e].copy())
        self.points = [r.point for r in results]
        return results

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
                f"state holds {len(state['episode'])} environments, this has {self.num_envs}"
            )
        self.episode = [int(j) for j in state["episode"]]
        self.actions = [list(a.numpy()) for a in state["actions"]]
        seeds = [episode_seed(self.seed, e, j) for e, j in enumerate(self.episode)]
        self.points = self.backend.replay(seeds, self.actions)
        got = [_digest(p) for p in self.points]
        if got != list(state["digest"]):
            bad = [e for e, (a, b) in enumerate(zip(got, state["digest"], strict=True)) if a != b]
            raise RuntimeError(
                f"replaying the saved options of environments {bad} did not reproduce their "
                "saved decision points: the environment is not deterministic given its seed "
                "and actions (or the task changed since the checkpoint)"
            )

    def close(self) -> None:
        self.backend.close()
