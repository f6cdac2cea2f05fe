"""The ``ray`` backend: environments in Ray actors, on this machine or across a cluster.

Ray is an optional extra (``maopg[ray]``; :func:`maopg.extras.install_hint` says how to
install it): this module imports it only when a :class:`RayVectorEnv` is built.
``num_workers`` actors each hold a slice of the environments, built by the same bootstrap as
a spawned worker's (:func:`~maopg.env.vector.worker_envs`: the run's plugins, then what the
parent registered). Everything that decides what is simulated
stays in the main process (:class:`~maopg.env.vector.SeededVectorEnv`), so a run's learning
curve is the same as with ``backend=local`` for any number of actors, and the local backend's
own random streams are untouched.

**Where.** With ``ray.address`` unset the backend starts a local Ray instance itself (and stops
it at the end); ``ray.address=auto`` joins the cluster this machine belongs to (``ray start
--head`` on one machine, ``ray start --address=HEAD:6379`` on the others), any other value is
given to ``ray.init(address=...)``. If the program has already called ``ray.init`` that
instance is used as it is. Every machine needs the same maopg (and plugin files) installed.

**A worker that dies** (a machine lost, an out-of-memory kill) is replaced: the backend keeps,
per environment, the seed of its current episode and the joint options applied since its reset
(the same log a checkpoint holds), so a new actor replays them — the simulation is
deterministic given seed and options — checks that it arrived at the same decision points
(fingerprints), and redoes the call that failed. No option step is lost or applied twice, so
the curve is the uninterrupted one. A worker that keeps dying (more than
``ray.max_replacements`` times in a run) ends the run with an error instead of looping.

**Cost.** Each lockstep option step is one exchange per actor: the joint options go out, the
next decision points (observations, images) come back. Ray places, starts, watches and replaces
the actors, but the exchanges themselves travel over a TCP connection from this process to each
actor (``ray.direct``, on by default; the actor checks a per-run key before it reads a pickle):
one round trip and the answer's bytes. A Ray actor call instead goes through Ray's scheduling
and object-store bookkeeping, which cost milliseconds per call on a small machine
(``bench/perf/backends.py`` measures both). An actor stepping ``k`` environments spreads the round
trip over ``k`` environments' physics, so across machines give each actor as many environments
as it takes for physics to dominate it (``bench/perf/scale_out.py`` measures the terms;
docs/DESIGN.md §9 works the numbers). A driver connected through Ray Client (``ray://``) may
not reach the actors' machines, and uses actor calls.
"""

from __future__ import annotations

import contextlib
import hmac
import logging
import math
import os
import secrets
import socket
import traceback
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from maopg.env.contract import DecisionPoint, EnvSpec
from maopg.env.ray_options import RayOptions, missing_ray, ray_available
from maopg.env.vector_base import (
    EnvConfig,
    SplitVectorEnv,
    digest,
    registrations,
    split_envs,
    worker_envs,
)
from maopg.plugins import env_plugins

log = logging.getLogger(__name__)


class EnvActor:
    """The body of one Ray actor: a slice of the environments (see the module docstring)."""

    def __init__(
        self,
        config: EnvConfig,
        env_indices: list[int],
        run_seed: int,
        registered: bytes,
        plugins: list[str],
    ) -> None:
        self.envs = worker_envs(config, env_indices, run_seed, registered, plugins)

    def call(self, name: str, *args: Any) -> Any:
        """``LocalVectorEnv.<name>(*args)``, one answer per environment: called with
        ``num_returns`` = the number of environments, so that each answer travels as an object
        of its own — small enough to ride inline in the reply instead of through the object
        store (Ray's ``max_direct_call_object_size``, 100 KiB), one more hop avoided. Ray
        takes a single return value as it is."""
        answers = getattr(self.envs, name)(*args)
        return answers[0] if len(answers) == 1 else tuple(answers)

    def spec(self) -> EnvSpec:
        return self.envs.spec()

    def pid(self) -> int:
        """The actor's process id (for tests that kill it)."""
        return os.getpid()

    def listen(self, key: bytes) -> tuple[str, int]:
        """Open the port :meth:`serve` will answer on; the address the driver connects to."""
        import ray

        self._key = key
        self._server = socket.create_server((ray.util.get_node_ip_address(), 0))
        return self._server.getsockname()[:2]

    def serve(self) -> None:
        """Answer the driver over its connection until it closes it: requests ``(name,
        args)``, answers ``(True, result)`` or ``(False, traceback)``. One request at a time,
        all on this thread (an EGL context is current on one thread only). A connection that
        does not open with the run's key is closed unread, and the actor waits for the next."""
        with self._server:
            while True:
                sock = self._server.accept()[0]
                if hmac.compare_digest(_read_key(sock, len(self._key)), self._key):
                    break
                sock.close()
        with _connection(sock) as conn:
            while True:
                try:
                    name, args = conn.recv()
                except EOFError:
                    return
                try:
                    result = self.pid() if name == "pid" else getattr(self.envs, name)(*args)
                    answer = (True, result)
                except Exception:  # the driver raises it, with this traceback
                    answer = (False, traceback.format_exc())
                conn.send(answer)


CONNECT_TIMEOUT_S = 10.0
"""How long to wait for a cluster address, or an actor's port, to answer before calling it
unreachable."""
LIVENESS_S = 1.0
"""How often a driver waiting on an actor's answer asks Ray whether the actor is still alive
(a lost machine may not close the connection)."""


def _read_key(sock: socket.socket, size: int) -> bytes:
    """The first ``size`` raw bytes a connection sends (``b""`` if they do not all come within
    ``CONNECT_TIMEOUT_S``): a stranger who sends a few bytes and falls silent does not hold
    the port."""
    sock.settimeout(CONNECT_TIMEOUT_S)
    offered = b""
    with contextlib.suppress(OSError):
        while len(offered) < size and (chunk := sock.recv(size - len(offered))):
            offered += chunk
    return offered


def _connection(sock: socket.socket) -> Connection:
    """A pickling connection over ``sock``: without Nagle's delay (a message is sent as its
    length and then its bytes, and the second write must not wait for the first's
    acknowledgement), and with TCP keep-alive probes, so that a read from a machine that
    vanished mid-answer fails within about half a minute instead of waiting forever."""
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
    for option, value in (("TCP_KEEPIDLE", 10), ("TCP_KEEPINTVL", 5), ("TCP_KEEPCNT", 3)):
        if hasattr(socket, option):  # Linux; elsewhere the system's defaults
            sock.setsockopt(socket.IPPROTO_TCP, getattr(socket, option), value)
    sock.settimeout(None)
    return Connection(sock.detach())


def _check_reachable(address: str) -> None:
    """Fail fast on an address nothing listens at: ``ray.init`` itself retries for minutes."""
    host, _, port = address.removeprefix("ray://").rpartition(":")
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as err:
        raise ValueError(f"ray.address={address!r}: no Ray cluster answers there ({err})") from None


def _connect(options: RayOptions, num_actors: int) -> bool:
    """Make sure this process is connected to Ray; True if it started the instance itself."""
    import ray

    if ray.is_initialized():
        return False
    settings: dict[str, Any] = {"logging_level": logging.WARNING, "include_dashboard": False}
    if options.address is None:
        # A local instance: enough logical CPUs for every actor, even on a small machine.
        wanted = math.ceil(num_actors * options.cpus_per_actor)
        settings["num_cpus"] = max(os.cpu_count() or 1, wanted)
    else:
        if options.address != "auto":
            _check_reachable(options.address)
        settings["address"] = options.address
    try:
        ray.init(**settings)
    except ConnectionError as err:
        raise ValueError(
            f"ray.address={options.address!r}: cannot join a Ray cluster: {err}"
        ) from None
    return True


class RayVectorEnv(SplitVectorEnv):
    """Environments split over ``num_actors`` Ray actors; dead actors are replaced and their
    step redone (module docstring)."""

    def __init__(
        self,
        config: EnvConfig,
        num_envs: int,
        run_seed: int,
        *,
        num_actors: int = 1,
        options: RayOptions | None = None,
    ) -> None:
        if not ray_available():
            raise ValueError(missing_ray())
        import ray

        self.options = options or RayOptions()
        if num_actors < 1:
            raise ValueError(f"num_workers (Ray actors) must be >= 1, got {num_actors}")
        self.num_envs = num_envs
        self.groups = split_envs(num_envs, num_actors)
        self._owns_ray = _connect(self.options, len(self.groups))
        self._remote = ray.remote(EnvActor).options(
            num_cpus=self.options.cpus_per_actor, max_restarts=0
        )
        self._build_args = (config, run_seed, registrations(config.task), env_plugins())
        self._key = secrets.token_bytes(32)
        self.actors: list[Any] = [None] * len(self.groups)
        self.links: list[Connection | None] = [None] * len(self.groups)
        """Actor ``k``'s direct connection, or ``None`` where it is reached by actor calls."""
        self.serving: list[Any] = [None] * len(self.groups)
        """Actor ``k``'s :meth:`EnvActor.serve` task: it fails when the actor dies."""
        for k in range(len(self.groups)):
            self._spawn(k)
        try:  # after every actor is started, so that they build their environments in parallel
            for k in range(len(self.groups)):
                self._connect(k)
        except BaseException:
            self.close()
            raise
        # What each environment's current episode is made of, to rebuild it on a new actor.
        self.seeds: list[int | None] = [None] * num_envs
        self.actions: list[list[np.ndarray]] = [[] for _ in range(num_envs)]
        self.points: list[DecisionPoint | None] = [None] * num_envs
        """Each environment's latest point, which a replacement must arrive at again."""
        self.replacements = 0

    def _spawn(self, k: int) -> None:
        """Start actor ``k`` (it builds its environments in the background)."""
        config, run_seed, registered, plugins = self._build_args
        actor = self._remote.remote(config, self.groups[k], run_seed, registered, plugins)
        self.actors[k], self.links[k], self.serving[k] = actor, None, None

    def _connect(self, k: int) -> None:
        """With ``ray.direct``, open the connection to actor ``k``."""
        import ray

        if not self.options.direct or ray.util.client.ray.is_connected():
            return
        address = ray.get(self.actors[k].listen.remote(self._key))
        self.serving[k] = self.actors[k].serve.remote()
        try:
            sock = socket.create_connection(address, timeout=CONNECT_TIMEOUT_S)
        except OSError as err:
            raise ValueError(
                f"ray.direct=true: cannot connect to Ray actor {k} at {address[0]}:"
                f"{address[1]} ({err}); ray.direct=false steps the actors by Ray actor calls"
            ) from None
        sock.sendall(self._key)
        self.links[k] = _connection(sock)

    # ------------------------------------------------------------------ calls
    def _split(self, call: str, *per_env_args: Sequence[Any]) -> list[Any]:
        sliced = [tuple([arg[e] for e in group] for arg in per_env_args) for group in self.groups]
        futures = [self._submit(k, call, args) for k, args in enumerate(sliced)]
        results: list[Any] = []
        for k, future in enumerate(futures):
            results.extend(self._result(k, future, lambda k=k: self._submit(k, call, sliced[k])))
        self._record(call, per_env_args, results)
        return results

    def _submit(self, k: int, call: str, args: tuple) -> list[Any] | None:
        """Ask actor ``k`` for ``call``: over its connection (``None``: the answer is read from
        it), or by an actor call with one object reference per environment of its group."""
        link = self.links[k]
        if link is not None:
            with contextlib.suppress(OSError):  # the actor is gone: reading finds out how
                link.send((call, args))
            return None
        n = len(self.groups[k])
        refs = self.actors[k].call.options(num_returns=n).remote(call, *args)
        return [refs] if n == 1 else list(refs)

    def _get(self, k: int, future: list[Any] | None) -> Any:
        """The answer to :meth:`_submit`; ``RayActorError`` if actor ``k`` died, and a
        ``RuntimeError`` with the actor's traceback if the environments raised."""
        import ray

        if future is not None:
            try:
                return ray.get(future)
            except ray.exceptions.RayTaskError as err:
                if isinstance(err, ray.exceptions.RayActorError):
                    raise  # a death: _result replaces the actor
                ok, answer = False, err
        else:
            ok, answer = self._read(k)
        if not ok:
            raise RuntimeError(f"environment actor {k} failed:\n{answer}")
        return answer

    def _read(self, k: int) -> tuple[bool, Any]:
        """Actor ``k``'s answer from its connection, watching that the actor stays alive."""
        import ray

        link = self.links[k]
        assert link is not None
        try:
            while not link.poll(LIVENESS_S):
                if ray.wait([self.serving[k]], timeout=0)[0]:
                    raise EOFError  # the serve task ended: its outcome says why, below
            ok, answer = link.recv()
        except (EOFError, OSError):
            # A dead actor raises RayActorError here. A connection lost to a live actor (a
            # reset on the network) is treated the same: the actor is killed and replaced.
            if ray.wait([self.serving[k]], timeout=CONNECT_TIMEOUT_S)[0]:
                ray.get(self.serving[k])
            raise ray.exceptions.RayActorError() from None
        return ok, answer

    def _result(self, k: int, future: Any, again: Callable[[], Any]) -> Any:
        """Actor ``k``'s answer; if the actor died, replace it and ask ``again()``."""
        import ray

        while True:
            try:
                return self._get(k, future)
            except ray.exceptions.RayActorError as err:
                self._replace(k, err)
                future = again()

    def _record(self, call: str, per_env_args: Sequence[Sequence[Any]], results: list) -> None:
        """Keep each environment's episode log in step with what the actors just did."""
        if call == "step":
            joints, next_seeds = per_env_args
            for e, result in enumerate(results):
                if result.final is not None:
                    self.seeds[e], self.actions[e] = int(next_seeds[e]), []
                else:
                    self.actions[e].append(np.array(joints[e], dtype=np.int64))
            points = [r.point for r in results]
        elif call in ("reset", "replay"):
            self.seeds = [int(s) for s in per_env_args[0]]
            self.actions = (
                [[] for _ in range(self.num_envs)]
                if call == "reset"
                else [[np.array(j, dtype=np.int64) for j in a] for a in per_env_args[1]]
            )
            points = results
        else:
            return
        self.points = list(points)

    def _replace(self, k: int, err: Exception) -> None:
        """A new actor for group ``k``, brought to where the dead one was."""
        import ray

        group = self.groups[k]
        while True:
            if self.replacements >= self.options.max_replacements:
                raise RuntimeError(
                    f"Ray actor {k} (environments {group}) died again after "
                    f"{self.replacements} replacements (ray.max_replacements): {err}"
                )
            self.replacements += 1
            reason = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            log.warning("Ray actor %d (environments %s) died; replacing it: %s", k, group, reason)
            self._disconnect(k)
            ray.kill(self.actors[k], no_restart=True)
            try:
                self._spawn(k)
                self._connect(k)
                if self.seeds[group[0]] is None:
                    return  # not reset yet: nothing to rebuild
                seeds = [self.seeds[e] for e in group]
                actions = [self.actions[e] for e in group]
                points = self._get(k, self._submit(k, "replay", (seeds, actions)))
            except ray.exceptions.RayActorError as again:
                err = again
                continue
            if [digest(p) for p in points] != [digest(self.points[e]) for e in group]:
                raise RuntimeError(
                    f"the replacement of Ray actor {k} did not reproduce the decision points "
                    f"of environments {group}: the environment is not deterministic given its "
                    "seed and options"
                )
            return

    def _disconnect(self, k: int) -> None:
        link, self.links[k] = self.links[k], None
        if link is not None:
            link.close()

    def _ask(self, k: int, name: str) -> Any:
        """A question for actor ``k`` alone (not one per environment)."""
        if self.links[k] is not None:
            return self._result(k, self._submit(k, name, ()), lambda: self._submit(k, name, ()))

        def call() -> Any:
            return getattr(self.actors[k], name).remote()

        return self._result(k, call(), call)

    def spec(self) -> EnvSpec:
        return self._ask(0, "spec")

    def pids(self) -> list[int]:
        """The actors' process ids (a test kills one to check the replacement)."""
        return [self._ask(k, "pid") for k in range(len(self.actors))]

    def close(self) -> None:
        import ray

        for k in range(len(self.actors)):
            self._disconnect(k)
        if not ray.is_initialized():
            return
        for actor in self.actors:
            ray.kill(actor, no_restart=True)
        if self._owns_ray:
            ray.shutdown()
