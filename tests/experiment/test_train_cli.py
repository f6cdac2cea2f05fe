"""The ``train`` command line on the real tasks: every method (MAPPO's and Mac-DQN), resume after
a kill, the rollout video, bad input."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import imageio.v2 as imageio
import pytest
import torch

from maopg.env.rollout import run_episode
from maopg.experiment.cli.train_cli import main, parse_args
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import WORKERS_PER_CORE, TrainConfig, parse_overrides
from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.experiment.run.methods import get_method, method_names
from maopg.learner import CheckpointError, MacDQNConfig, PPOConfig, load_checkpoint
from maopg.tasks import task_names

REPO = Path(__file__).resolve().parents[2]
RUN = [
    "batch_ticks=60",
    "backend=threads",  # every task, whatever its default (spawning workers costs seconds)
    "num_envs=2",
    "progress=false",
    "video=false",
    "eval_episodes=0",
    "plot=false",
    "checkpoint_every=2",
]
SECTION = {
    "ppo": ["ppo.epochs=2"],
    "dqn": ["dqn.learning_starts=40", "dqn.train_every=20"],
    "acac": ["acac.episodes_per_update=1"],
    "maciaicc": ["maciaicc.episodes_per_update=1"],
}


def tiny(method: str = "async") -> list[str]:
    """A few-second run of ``method``: small batches, and its learner's section shortened."""
    return ["--method", method, *RUN, *SECTION[get_method(method).section]]


TINY = tiny()


def _rows(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as handle:
        return list(csv.DictReader(handle))


def _deterministic(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]


def test_overrides_are_typed_and_checked(capsys):
    values = parse_overrides(
        [
            "ppo.epochs=5",
            "ppo.lr=1e-3",
            "images=false",
            "total_samples=2_000",
            "env.max_ticks=50",
        ],
        "async",
    )
    assert values == {
        "ppo": {"epochs": 5, "lr": 1e-3},
        "images": False,
        "total_samples": 2000,
        "env_overrides": {"max_ticks": 50},
    }
    dqn = parse_overrides(["dqn.lr=2e-4", "dqn.recurrent=yes"], "mac-dqn")
    assert dqn == {"dqn": {"lr": 2e-4, "recurrent": True}}
    with pytest.raises(ValueError, match=r"unknown setting 'epoch': did you mean 'ppo\.epochs'"):
        parse_overrides(["epoch=5"], "async")
    with pytest.raises(ValueError, match=r"unknown setting 'dqn\.epochs'"):
        parse_overrides(["dqn.epochs=5"], "mac-dqn")
    with pytest.raises(ValueError, match="reads the 'ppo' section, not 'dqn'"):
        parse_overrides(["dqn.lr=1e-3"], "async")
    with pytest.raises(ValueError, match="expected int"):
        parse_overrides(["ppo.epochs=many"], "async")
    config, _ = parse_args(["--method", "mac-dqn", "dqn.train_every=7"])
    assert (
        config.learner == MacDQNConfig(train_every=7) and config.resolved().strategy == "continue"
    )
    assert TrainConfig.from_dict(config.to_dict()) == config
    assert "ppo" not in config.to_dict() and config.to_dict()["dqn"]["train_every"] == 7
    config, _ = parse_args(["--method", "sync-wait", "--seed", "3", "ppo.discount=option"])
    resolved = config.resolved()
    assert resolved.strategy == "all" and get_method("sync-wait").learner_class.section == "ppo"
    assert resolved.batch_ticks == 200 and resolved.learner.discount == "option"
    assert resolved.run_dir == os.path.join("runs", "tool_delivery", "sync-wait", "seed3")
    with pytest.raises(ValueError, match="unknown method"):
        TrainConfig(method="nope").resolved()


PER_ENV = min(4, WORKERS_PER_CORE * (os.cpu_count() or 1))
"""``num_workers=0`` with ``processes`` and the default 4 environments: one worker each."""


@pytest.mark.parametrize(
    ("task", "settings", "backend", "workers"),
    [
        ("tool_delivery", {}, "threads", 0),
        ("water_filling", {}, "processes", PER_ENV),  # the task's default
        ("water_filling", {"num_envs": 64}, "processes", WORKERS_PER_CORE * os.cpu_count()),
        ("water_filling", {"num_envs": 1}, "processes", 1),
        ("water_filling", {"backend": "threads"}, "threads", 0),
        ("tool_delivery", {"num_workers": 3}, "processes", 3),
        ("tool_delivery", {"backend": "processes"}, "processes", PER_ENV),
    ],
)
def test_the_backend_defaults_to_the_tasks_own(task, settings, backend, workers):
    resolved = TrainConfig(task=task, **settings).resolved()
    assert (resolved.backend, resolved.num_workers) == (backend, workers)


@pytest.mark.parametrize(("task", "images"), [("tool_delivery", True), ("water_filling", False)])
def test_each_task_also_trains_from_its_other_observation_kind(tmp_path, task, images):
    """Tool Delivery defaults to state vectors and Water Filling to RGB; both switch."""
    run_dir = tmp_path / "run"
    flag = "--images" if images else "--no-images"
    args = ["--task", task, "--method", "async", flag, "--total-samples", "120"]
    main([*args, "--run-dir", str(run_dir), *TINY, "env.max_ticks=40"])
    final = load_checkpoint(run_dir / "final.pt")
    assert final["config"]["images"] is images
    assert int(_rows(run_dir)[-1]["samples"]) >= 120


def test_flat_mappo_keys_are_deprecated_aliases(capsys):
    """On the command line; saved configs with flat keys: tests/experiment/test_migration.py."""
    config, _ = parse_args(["--method", "async", "epochs=3", "lr=1e-3"])
    assert config.learner == PPOConfig(epochs=3, lr=1e-3)
    assert "deprecated" in capsys.readouterr().err
    with pytest.raises(ValueError, match="is a MAPPO hyper-parameter"):
        parse_args(["--method", "mac-dqn", "epochs=3"])  # Mac-DQN has no MAPPO section


@pytest.mark.parametrize("method", method_names())
@pytest.mark.parametrize("task", task_names())
def test_every_method_trains_a_tiny_budget(tmp_path, task, method):
    run_dir = tmp_path / method
    task = ["--task", task, "--seed", "0", *tiny(method)]
    # 40-tick episodes: some end in the budget, so Mac-DQN's replay can serve updates
    main([*task, "--total-samples", "120", "--run-dir", str(run_dir), "env.max_ticks=40"])
    rows = _rows(run_dir)
    assert len(rows) >= 2 and list(rows[0]) == list(get_method(method).columns)
    assert int(rows[-1]["samples"]) >= 120
    for row in rows:
        assert int(row["option_steps"]) > 0
        assert float(row["samples_per_s"]) > 0
        if method == "mac-dqn":
            assert 0 < float(row["epsilon"]) <= 1
        else:
            assert float(row["entropy"]) >= 0
    for name in ("config.json", "checkpoint.pt", "final.pt"):
        assert (run_dir / name).is_file(), name
    for name in ("rollout.mp4", "learning_curve.png"):  # video=false, plot=false
        assert not (run_dir / name).exists(), name
    assert any((run_dir / "tb").iterdir())
    final = load_checkpoint(run_dir / "final.pt")
    assert final["config"]["method"] == method
    assert final["samples"] == int(rows[-1]["samples"])
    if method == "mac-dqn":
        assert int(rows[-1]["updates"]) > 0 and float(rows[-1]["loss"]) >= 0
        # resuming a finished run with a larger budget continues it
        main(["--resume", "--run-dir", str(run_dir), "--total-samples", "180", "progress=false"])
        resumed = _rows(run_dir)
        assert resumed[: len(rows)] == rows and int(resumed[-1]["samples"]) >= 180
        assert int(resumed[-1]["updates"]) > int(rows[-1]["updates"])
        assert json.loads((run_dir / "done.json").read_text())["samples"] >= 180


@pytest.mark.parametrize(
    ("method", "samples", "extra"),
    [
        ("async", 1200, ["eval_every=120", "eval_during_episodes=1", "env.max_ticks=40"]),
        ("partial-rnn", 480, []),
        ("async-rnn", 480, ["ppo.option_history=true", "ppo.memory_norm=true"]),
        ("acac", 600, ["env.max_ticks=40"]),
        ("mac-iaicc", 600, ["env.max_ticks=40"]),
        ("async", 360, ["--images", "env.appearance=full", "env.max_ticks=40"]),
    ],
)
def test_kill_and_resume_reproduces_the_uninterrupted_run(tmp_path, capsys, method, samples, extra):
    """Bit for bit, curve and weights; recurrent runs (per-agent GRU states, carried across
    iterations; GRUs that read the option history) included: their states are in the
    checkpoint. A recurrent run without ``ppo.memory_norm`` is told at its start. The
    evaluation during training (``eval_every``) is in the curve: its rows up to the
    checkpoint survive the kill and the resumed run evaluates where the reference did. A run
    from images in randomised looks (``env.appearance=full``) replays each episode's look."""
    common = ["--seed", "5", "--total-samples", str(samples), *tiny(method), *extra]
    reference = tmp_path / "reference"
    main([*common, "--run-dir", str(reference)])
    raw_gru = method.endswith("-rnn") and "ppo.memory_norm=true" not in extra
    assert ("ppo.recurrent=true without ppo.memory_norm=true" in capsys.readouterr().err) == raw_gru

    killed = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-m", "train", *common, "--run-dir", str(killed)],
        cwd=REPO,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 120
    while not (killed / "checkpoint.pt").exists():
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline, "no checkpoint within 120 s"
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    interrupted_rows = len(_rows(killed))
    assert interrupted_rows < len(_rows(reference)), "the run finished before it was killed"
    evaluated = [row["eval_return"] != "nan" for row in _rows(killed) if "eval_return" in row]
    assert any(evaluated) == ("eval_every=120" in extra), "an evaluation logged before the kill"
    assert not (killed / "final.pt").exists() and not (killed / "done.json").exists()

    # resumed in a fresh process, as after a crash: nothing of the reference run's process
    # (the critic's thread once carried bits across, maopg.learner.beside) helps
    resume = [sys.executable, "-m", "train", "--resume", "--run-dir", str(killed)]
    subprocess.run([*resume, "progress=false"], cwd=REPO, check=True, stdout=subprocess.DEVNULL)
    assert _deterministic(_rows(killed)) == _deterministic(_rows(reference))
    if "eval_every=120" in extra:  # ten evaluations, compared above
        assert sum(row["eval_return"] != "nan" for row in _rows(reference)) == 10
    assert json.loads((killed / "done.json").read_text())["samples"] >= samples
    resumed, uninterrupted = (load_checkpoint(d / "final.pt") for d in (killed, reference))
    for network in ("policy", "critic"):
        for name, tensor in uninterrupted[network].items():
            assert torch.equal(resumed[network][name], tensor), (network, name)


def test_a_second_run_in_one_process_gives_the_first_runs_curve(tmp_path):
    """Nothing a run leaves in the process changes the next one's bits: the critic's thread
    once did, for a recurrent critic (``maopg.learner.beside``: then one thread
    for the process, the second run left the first's curve at iteration 2)."""
    common = ["--seed", "5", "--total-samples", "360", *tiny("async-rnn")]
    for name in ("first", "second"):
        main([*common, "--run-dir", str(tmp_path / name)])
    first, second = (_deterministic(_rows(tmp_path / n)) for n in ("first", "second"))
    assert first == second


def test_a_recurrent_curve_does_not_depend_on_openmp_threads(tmp_path):
    """The critic's thread computes on the run's torch threads, not OpenMP's default (a GRU's
    small steps never made torch apply the setting to a new thread)."""
    common = ["-m", "train", "--seed", "5", "--total-samples", "240", *tiny("partial-rnn")]
    for name, omp in (("default", None), ("one", "1")):
        env = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}
        env |= {"OMP_NUM_THREADS": omp} if omp else {}
        argv = [sys.executable, *common, "--run-dir", str(tmp_path / name)]
        subprocess.run(argv, cwd=REPO, env=env, check=True, stdout=subprocess.DEVNULL)
    default, one = (_deterministic(_rows(tmp_path / n)) for n in ("default", "one"))
    assert default == one


@pytest.mark.parametrize(
    ("task", "backend", "method"),
    [
        ("tool_delivery", "threads", "async"),
        ("water_filling", "processes", "async"),  # its default: one worker per environment
        ("tool_delivery", "threads", "async-rnn"),
        ("water_filling", "processes", "acac"),
    ],
)
def test_every_backend_gives_the_same_curve_as_in_process(tmp_path, task, backend, method):
    """From images; a recurrent run too (its GRU states live in the learner, never in the
    environments' workers), and ACAC, whose rounds (Mac-IAICC's too) restart and discard
    episodes across the workers (Ray's backend: ``tests/env/test_ray_backend.py``)."""
    common = ["--task", task, "--seed", "2", "--total-samples", "240", *tiny(method), "--images"]
    main([*common, "--run-dir", str(tmp_path / "serial"), "backend=local"])
    main([*common, "--run-dir", str(tmp_path / backend), f"backend={backend}", "num_workers=0"])
    if backend == "processes":  # num_workers=0: one worker per environment (num_envs=2)
        assert load_checkpoint(tmp_path / backend / "final.pt")["config"]["num_workers"] == 2
    serial = _deterministic(_rows(tmp_path / "serial"))
    assert serial == _deterministic(_rows(tmp_path / backend))


def test_existing_run_needs_resume_and_corrupt_checkpoint_is_named(tmp_path, user_error):
    run_dir = tmp_path / "run"
    args = ["--total-samples", "60", "--run-dir", str(run_dir), *TINY]
    main(args)
    user_error(main, args, "already holds a run; pass --resume")
    # a finished run resumes as a no-op, even where its checkpoint is gone (a fresh clone)
    checkpoint = run_dir / "checkpoint.pt"
    saved = checkpoint.read_bytes()
    checkpoint.unlink()
    metrics = (run_dir / "metrics.csv").read_text()
    main(["--resume", "--run-dir", str(run_dir), "progress=false"])
    assert (run_dir / "metrics.csv").read_text() == metrics and not checkpoint.exists()
    checkpoint.write_bytes(saved[:100])
    resume = ["--resume", "--run-dir", str(run_dir), "--total-samples", "200"]
    user_error(main, resume, f"checkpoint {checkpoint} is corrupt")
    with pytest.raises(CheckpointError, match=str(checkpoint)):  # --debug: the traceback
        main([*resume, "--debug"])
    # the failed extension left no final policy behind to be mistaken for its result
    assert not (run_dir / "final.pt").exists() and not (run_dir / "done.json").exists()
    user_error(main, ["--resume", "--run-dir", str(run_dir), "--seed", "9"], r"seed \(saved 0")


@pytest.mark.parametrize("method", ["async", "mac-dqn", "partial-rnn", "acac", "mac-iaicc"])
def test_video_of_the_trained_policy(tmp_path, method):
    """``video=true`` leaves the seed-0 episode of the policy saved in ``final.pt``, sampled as
    in training (``video_sample=false``: greedy); a recurrent policy's too (its actor carries
    the GRU states through the episode), the literature's agent-centric actors' included."""
    run_dir = tmp_path / method
    args = ["--total-samples", "60", "--run-dir", str(run_dir), *tiny(method)]
    main([*args, "video=true", "env.max_ticks=30"])
    trained = load_trained(run_dir)
    env = trained.make_env(0)
    try:
        episode = run_episode(env, trained.actor(greedy=False), seed=0)
    finally:
        env.close()
    reader = imageio.get_reader(run_dir / "rollout.mp4")
    try:
        frames = [frame.shape for frame in reader.iter_data()]
    finally:
        reader.close()
    assert len(frames) == 4 * episode.ticks + 1 and 0 < episode.ticks <= 30
    assert len(set(frames)) == 1 and frames[0][0] >= 64 and frames[0][2] == 3


def test_the_learning_curve_is_drawn_unless_plot_is_false(tmp_path):
    """The default draws ``learning_curve.png``; ``plot`` is resumable, and an extended run
    with ``plot=false`` leaves no curve of the shorter run behind."""
    run_dir = tmp_path / "run"
    args = ["--total-samples", "60", "--run-dir", str(run_dir), *TINY]
    main([*args, "plot=true"])
    image = imageio.imread(run_dir / "learning_curve.png")
    assert image.ndim == 3 and image.shape[0] > 100
    main([*args[:1], "120", *args[2:], "--resume"])  # plot=false (TINY) from here on
    assert len(_rows(run_dir)) == 2 and not (run_dir / "learning_curve.png").exists()


def test_a_users_registered_task_gets_generic_defaults(tmp_path, monkeypatch):
    from maopg.tasks import registry

    monkeypatch.setattr(registry, "_TASKS", dict(registry._TASKS))
    registry.register_task("my_delivery", "maopg.tasks.tool_delivery.task:ToolDelivery")
    config = TrainConfig(task="my_delivery", total_samples=100, run_dir=str(tmp_path / "r"))
    assert config.resolved().batch_ticks == 1000
    with pytest.raises(ValueError, match="unknown task 'nope'"):
        TrainConfig(task="nope").resolved()


def test_method_as_a_key_value_picks_its_section():
    config, _ = parse_args(["method=mac-dqn", "dqn.train_every=9"])
    assert config.method == "mac-dqn" and config.learner == MacDQNConfig(train_every=9)
