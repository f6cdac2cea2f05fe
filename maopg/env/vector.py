"""Vector environments: ``E`` option environments stepped in lockstep, behind one interface.

A :class:`VectorEnv` backend only builds and steps environments; the backends differ in where
the environments live (:class:`LocalVectorEnv`: this process; :class:`ThreadVectorEnv`: this
process, on threads; :class:`ProcessVectorEnv`: ``spawn`` worker processes;
:class:`~maopg.env.ray_backend.RayVectorEnv`: Ray actors on any machine of a cluster), chosen
by name through :data:`BACKENDS`, so another distributed backend is one more implementation
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
The pieces every backend is built from (:class:`EnvConfig`, :class:`LocalVectorEnv`, the worker
bootstrap) are in :mod:`maopg.env.vector_base`, which a backend module of its own imports.

Rendering. A ``fork``ed child hangs if its parent already created a MuJoCo renderer
(docs/DESIGN.md §2), so workers are ``spawn``ed and the main process never builds an environment
when workers are used: it asks worker 0 for the :class:`~maopg.env.contract.EnvSpec`.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import traceback
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from multiprocessing.connection import Connection
from typing import Any

import numpy as np
import torch

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.env.vector_base import (
    EnvConfig,
    LocalVectorEnv,
    SplitVectorEnv,
    StepResult,
    VectorEnv,
    digest,
    episode_seed,
    registrations,
    split_envs,
    worker_envs,
)

__all__ = [
    "BACKENDS",
    "EnvConfig",
    "LocalVectorEnv",
    "ProcessVectorEnv",
    "SeededVectorEnv",
    "StepResult",
    "ThreadVectorEnv",
    "VectorEnv",
    "episode_seed",
    "register_backend",
]


class ThreadVectorEnv(SplitVectorEnv):
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
        self.groups = split_envs(num_envs, num_threads)
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


def _worker(
    conn: Connection,
    config: EnvConfig,
    env_indices: list[int],
    run_seed: int,
    registered: bytes,
) -> None:
    """Worker process loop: build the environments, then serve ``(call, args)`` requests."""
    envs = None
    try:
        envs = worker_envs(config, env_indices, run_seed, registered)
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


class ProcessVectorEnv(SplitVectorEnv):
    """Environments split over ``num_workers`` ``spawn``ed processes (at most one per env)."""

    def __init__(
        self, config: EnvConfig, num_envs: int, run_seed: int, *, num_workers: int = 2
    ) -> None:
        if num_workers < 1:
            raise ValueError(f"num_workers must be >= 1, got {num_workers}")
        ctx = mp.get_context("spawn")
        self.num_envs = num_envs
        self.groups = split_envs(num_envs, num_workers)
        registered = registrations(config.task)
        self.conns: list[Connection] = []
        self.procs = []
        for group in self.groups:
            parent, child = ctx.Pipe()
            args = (child, config, group, run_seed, registered)
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


BackendFactory = Callable[[EnvConfig, int, int, int, Mapping[str, Any]], VectorEnv]
"""``factory(config, num_envs, run_seed, num_workers, options)`` → a :class:`VectorEnv`;
``options`` are the backend's own settings (``ray.address=...`` for ``ray``; empty for the
others)."""

BACKENDS: dict[str, BackendFactory] = {}
"""Backend name → factory: the values of the ``backend=`` config key."""


def register_backend(name: str, factory: BackendFactory, *, overwrite: bool = False) -> None:
    """Make ``backend=name`` build environments with ``factory`` (a distributed backend, say)."""
    if name in BACKENDS and not overwrite:
        raise ValueError(f"backend {name!r} is already registered (pass overwrite=True)")
    BACKENDS[name] = factory


def _ray(
    config: EnvConfig, n: int, seed: int, workers: int, options: Mapping[str, Any]
) -> VectorEnv:
    """The Ray backend, imported only when chosen: Ray is an optional extra."""
    from maopg.env.ray_backend import RayOptions, RayVectorEnv

    return RayVectorEnv(config, n, seed, num_actors=max(workers, 1), options=RayOptions(**options))


register_backend("local", lambda config, n, seed, _w, _o: LocalVectorEnv(config, range(n), seed))
register_backend(
    "threads",
    lambda config, n, seed, workers, _o: ThreadVectorEnv(
        config, n, seed, num_threads=max(workers, 2)
    ),
)
register_backend(
    "processes",
    lambda config, n, seed, workers, _o: ProcessVectorEnv(config, n, seed, num_workers=workers),
)
register_backend("ray", _ray)


StepHook = Callable[[Sequence[DecisionPoint], np.ndarray, Sequence[StepResult]], None]
"""``hook(points acted on, joints [E, N], results)`` after a :meth:`SeededVectorEnv.step`."""


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
        backend_options: Mapping[str, Any] | None = None,
    ) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        if backend not in BACKENDS:
            raise ValueError(f"unknown backend {backend!r}; known: {sorted(BACKENDS)}")
        self.num_envs = num_envs
        self.seed = seed
        self.backend: VectorEnv = BACKENDS[backend](
            config, num_envs, seed, num_workers, dict(backend_options or {})
        )
        self.spec: EnvSpec = self.backend.spec()
        self.on_step: StepHook | None = None
        """Called after each :meth:`step` with the points acted on, the joints and the results:
        the trainer's hook for its progress bar (ticks inside a learner's batch, not only
        after it) and the logged option choices, which no learner needs to know about."""
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

    def restart(self) -> None:
        """Leave every environment's current episode unfinished and start its next one (its
        next episode seed): for a learner that collects whole episodes from a common start,
        as ACAC's rounds do. The abandoned episodes report nothing."""
        if not self.points:
            raise RuntimeError("call reset() or load_state_dict() before restart()")
        self.episode = [j + 1 for j in self.episode]
        self.actions = [[] for _ in range(self.num_envs)]
        self.points = self.backend.reset(
            [episode_seed(self.seed, e, j) for e, j in enumerate(self.episode)]
        )

    def step(self, joints: np.ndarray) -> list[StepResult]:
        """Apply one joint option per environment (``int64 [E, N]``), in lockstep.

        An environment whose episode ends is reset with its next episode seed at once; the
        result's ``final`` then holds the episode's last point. The returned points become
        :attr:`points`, and the options are logged for :meth:`state_dict`. Every point is a new
        object that owns its arrays (:meth:`DecisionPoint.copy`, or unpickled from a worker):
        a caller may keep it, and no later step changes it.
        """
        if not self.points:
            raise RuntimeError("call reset() or load_state_dict() before step()")
        next_seeds = [episode_seed(self.seed, e, j + 1) for e, j in enumerate(self.episode)]
        acted_on = self.points
        results = self.backend.step(joints, next_seeds)
        for e, result in enumerate(results):
            if result.final is not None:
                self.episode[e] += 1
                self.actions[e] = []
            else:
                self.actions[e].append(joints[e].copy())
        self.points = [r.point for r in results]
        if self.on_step is not None:
            self.on_step(acted_on, joints, results)
        return results

    def state_dict(self) -> dict[str, Any]:
        """Episode counters and the joint options of each current episode (checkpoint-safe)."""
        n = self.spec.num_agents
        return {
            "episode": list(self.episode),
            "actions": [
                torch.from_numpy(np.asarray(a, dtype=np.int64).reshape(-1, n)) for a in self.actions
            ],
            "digest": [digest(p) for p in self.points],
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
        got = [digest(p) for p in self.points]
        if got != list(state["digest"]):
            bad = [e for e, (a, b) in enumerate(zip(got, state["digest"], strict=True)) if a != b]
            raise RuntimeError(
                f"replaying the saved options of environments {bad} did not reproduce their "
                "saved decision points: the environment is not deterministic given its seed "
                "and actions (or the task changed since the checkpoint)"
            )

    def close(self) -> None:
        self.backend.close()
