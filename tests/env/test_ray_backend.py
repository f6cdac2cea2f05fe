"""The ``ray`` backend on a real local Ray instance with 2 CPUs: the same rollouts and learning
curves as ``backend=local`` for any number of actors, a killed actor replaced with no option
step lost or applied twice, resume, and its settings' errors.

Ray is the optional extra ``maopg[ray]``, which the test command installs; without it these
tests are skipped.
"""

from __future__ import annotations

import csv
import logging
import os
import signal
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from maopg.env.rollout import RandomPolicy
from maopg.env.vector import EnvConfig, SeededVectorEnv, digest
from maopg.experiment.cli.train_cli import main
from maopg.experiment.run.directory import TIMING_COLUMNS

ray = pytest.importorskip("ray")
# A parallel run (scripts/test.sh: pytest -n auto --dist loadfile) keeps this module on one
# worker: one Ray instance, and no other test's actors for the actor killer below to hit.

CONFIG = EnvConfig(task="tool_delivery", strategy="continue", images=True)
RUN = ["--seed", "1", "batch_ticks=100", "num_envs=3", "ppo.epochs=2", "progress=false"]
RUN += ["video=false", "eval_episodes=0", "checkpoint_every=2"]


@pytest.fixture(scope="module", autouse=True)
def local_ray():
    """One local Ray instance (2 CPUs) for the module; the backend uses it as it finds it."""
    ray.init(num_cpus=2, include_dashboard=False, logging_level=logging.WARNING)
    yield
    ray.shutdown()


def _trace(envs: SeededVectorEnv, steps: int, kill_at: int | None = None) -> list[list[str]]:
    """Fingerprints of every outcome of ``steps`` random lockstep option steps; with
    ``kill_at``, the last actor's process is killed (SIGKILL) before that step."""
    envs.reset()
    policy, trace = RandomPolicy(envs.spec, 0), []
    for step in range(steps):
        if step == kill_at:
            os.kill(envs.backend.pids()[-1], signal.SIGKILL)
        results = envs.step(np.stack([policy(p) for p in envs.points]))
        trace.append([digest(r.outcome) for r in results])
    return trace


def _envs(backend: str, workers: int = 0, **options: bool) -> SeededVectorEnv:
    return SeededVectorEnv(
        CONFIG, num_envs=3, seed=5, backend=backend, num_workers=workers, backend_options=options
    )


def _rows(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as handle:
        return [
            {k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in csv.DictReader(handle)
        ]


@pytest.fixture(scope="module")
def local_trace() -> list[list[str]]:
    envs = _envs("local")
    try:
        return _trace(envs, 40)
    finally:
        envs.close()


@pytest.mark.parametrize(("actors", "direct"), [(1, True), (2, True), (2, False)])
def test_ray_rollouts_equal_local_ones(local_trace, actors, direct):
    """Over direct connections (the default) and over Ray actor calls alike."""
    envs = _envs("ray", actors, direct=direct)
    try:
        assert len(envs.backend.actors) == actors
        assert all((link is not None) == direct for link in envs.backend.links)
        assert _trace(envs, 40) == local_trace
    finally:
        envs.close()


@pytest.mark.parametrize(
    "config",
    [
        EnvConfig(task="box_pushing_grid", strategy="continue"),
        EnvConfig(task="box_pushing", strategy="continue", images=True),
    ],
    ids=["grid", "mujoco-rgb"],
)
def test_box_pushing_rolls_out_alike_on_every_backend(config):
    """Both Box Pushing tasks, the grid and the task in MuJoCo from its cameras: the same
    random rollouts in this process, on threads, in ``spawn``ed worker processes and in Ray
    actors (every outcome's fingerprint: observations, images, conditions and ticks)."""
    traces = {}
    for backend, workers in (("local", 0), ("threads", 2), ("processes", 2), ("ray", 2)):
        envs = SeededVectorEnv(config, num_envs=2, seed=4, backend=backend, num_workers=workers)
        try:
            traces[backend] = _trace(envs, 10)
        finally:
            envs.close()
    assert all(trace == traces["local"] for trace in traces.values())


class _Planted:
    """A pickle that, if loaded, leaves a file behind: what a stranger could send."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (Path.touch, (self.path,))


def _connect(address: tuple[str, int], opening: bytes):
    """A connection to an actor's port that first sends ``opening`` as raw bytes."""
    from multiprocessing.connection import Connection

    sock = socket.create_connection(address, timeout=10)
    sock.sendall(opening)
    sock.setblocking(True)
    return Connection(sock.detach())


def test_an_actor_drops_a_connection_without_the_run_key_unread(tmp_path):
    """The actor's port takes pickles only after the run's key: a stranger's pickle is not
    loaded (no code of theirs runs), a stranger who falls silent does not hold the port, and
    the driver, with the key, is served after them."""
    from maopg.env.ray_backend import EnvActor
    from maopg.env.vector_base import registrations

    key = b"k" * 32
    actor = ray.remote(EnvActor).remote(CONFIG, [0], 5, registrations(CONFIG.task), [])
    try:
        address = ray.get(actor.listen.remote(key))
        serving = actor.serve.remote()
        stranger = _connect(address, b"x" * 32)
        stranger.send(_Planted(tmp_path / "planted"))
        silent = _connect(address, b"k" * 3)
        driver = _connect(address, key)
        driver.send(("pid", ()))
        assert driver.poll(60), "the driver was not served"
        ok, pid = driver.recv()
        assert ok and pid != os.getpid()  # answered by the actor, which serves one at a time
        assert not (tmp_path / "planted").exists()
        driver.close()
        assert ray.get(serving, timeout=60) is None
        stranger.close()
        silent.close()
    finally:
        ray.kill(actor)


def test_a_killed_actor_is_replaced_and_its_step_redone(local_trace, caplog):
    envs = _envs("ray", 2)
    try:
        before = envs.backend.pids()
        with caplog.at_level(logging.WARNING, logger="maopg.env.ray_backend"):
            assert _trace(envs, 40, kill_at=17) == local_trace
        assert envs.backend.replacements == 1
        assert envs.backend.pids()[0] == before[0] and envs.backend.pids()[1] != before[1]
        assert "Ray actor 1 (environments [2]) died; replacing it" in caplog.text
    finally:
        envs.close()


def test_checkpoint_replay_through_ray_actors(local_trace):
    source = _envs("local")
    twin = _envs("ray", 2)
    try:
        _trace(source, 12)
        twin.load_state_dict(source.state_dict())
        assert [digest(p) for p in twin.points] == [digest(p) for p in source.points]
    finally:
        source.close()
        twin.close()


def _kill_an_actor_once_training_runs(run_dir: Path, killed: list[int]) -> threading.Thread:
    """A thread that waits for the run's first logged iteration, then kills one Ray actor
    process (found by the process title Ray gives it), as a lost machine would."""

    def kill() -> None:
        deadline = time.monotonic() + 120
        metrics = run_dir / "metrics.csv"
        while time.monotonic() < deadline:
            if metrics.exists() and len(metrics.read_text().splitlines()) >= 2:
                break
            time.sleep(0.01)
        for pid in sorted(int(p) for p in os.listdir("/proc") if p.isdigit()):
            try:
                title = Path(f"/proc/{pid}/cmdline").read_bytes()
            except OSError:
                continue
            if title.startswith(b"ray::EnvActor"):
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
                return

    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    return thread


def test_training_curve_survives_a_killed_actor_and_resumes(tmp_path, caplog):
    """Mid-run, a Ray actor is killed: the curve is the uninterrupted local one; a resumed
    run (more samples, from the checkpoint, on Ray) continues it exactly."""
    main([*RUN, "--total-samples", "1200", "--run-dir", str(tmp_path / "local"), "backend=local"])

    run = tmp_path / "ray"
    killed: list[int] = []
    killer = _kill_an_actor_once_training_runs(run, killed)
    with caplog.at_level(logging.WARNING, logger="maopg.env.ray_backend"):
        args = [*RUN, "--total-samples", "800", "--run-dir", str(run)]
        assert main([*args, "backend=ray", "num_workers=2"]) == 0
    killer.join(timeout=5)
    assert killed, "no Ray actor was found to kill"
    assert "died; replacing it" in caplog.text, "the actor was killed after training ended"

    main(["--resume", "--run-dir", str(run), "--total-samples", "1200", "progress=false"])
    assert _rows(run) == _rows(tmp_path / "local")


@pytest.mark.parametrize("method", ["acac", "mac-iaicc"])
def test_the_literature_methods_train_the_same_curve_on_ray(tmp_path, method):
    """ACAC's and Mac-IAICC's rounds restart every environment and throw away the episodes a
    round leaves unfinished: through Ray actors their curves are the in-process ones."""
    section = {"acac": "acac", "mac-iaicc": "maciaicc"}[method]
    args = ["--task", "box_pushing_grid", "env.size=4", "--seed", "1", "--method", method]
    args += ["--total-samples", "300", "num_envs=3", f"{section}.episodes_per_update=2"]
    args += ["progress=false", "video=false", "eval_episodes=0"]
    main([*args, "--run-dir", str(tmp_path / "local"), "backend=local"])
    main([*args, "--run-dir", str(tmp_path / "ray"), "backend=ray", "num_workers=2"])
    assert _rows(tmp_path / "ray") == _rows(tmp_path / "local")


def _status(argv: list[str]) -> int:
    """``main``'s exit status, whether it returns it or argparse exits with it."""
    try:
        return main(argv)
    except SystemExit as exit:
        return int(exit.code or 0)


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ("ray.cpus_per_actor=0", r"ray\.cpus_per_actor must be > 0"),
        ("ray.max_replacements=-1", r"ray\.max_replacements must be >= 0"),
        ("ray.adress=auto", r"unknown setting 'ray\.adress': did you mean 'ray\.address'"),
        ("ray.direct=maybe", r"ray\.direct expected bool, got 'maybe'"),
        ("ray.address=nowhere", r"ray\.address='nowhere': expected HOST:PORT"),
        ("ray.address=127.0.0.1:1", r"ray\.address='127\.0\.0\.1:1': no Ray cluster answers"),
    ],
)
def test_bad_ray_settings_are_one_line_errors(tmp_path, user_error, setting, message):
    # An address is only read where this process is not connected to Ray yet.
    reconnect = "127.0.0.1" in setting
    if reconnect:
        ray.shutdown()
    try:
        run = tmp_path / "run"
        args = [*RUN, "--total-samples", "100", "--run-dir", str(run), "backend=ray", setting]
        user_error(_status, args, message)
        assert not run.exists(), "a failed start must leave nothing behind"
    finally:
        if reconnect:
            ray.init(num_cpus=2, include_dashboard=False, logging_level=logging.WARNING)


def test_backend_ray_without_ray_installed_says_how_to_get_it(tmp_path, user_error, monkeypatch):
    monkeypatch.setattr("maopg.experiment.run.config.ray_available", lambda: False)
    args = [*RUN, "--total-samples", "100", "--run-dir", str(tmp_path / "run"), "backend=ray"]
    # from this clone: its own extra, not a package of pip's index (maopg.extras)
    user_error(main, args, r"backend=ray needs Ray: pip install -e '\.\[ray\]' \(in /")
