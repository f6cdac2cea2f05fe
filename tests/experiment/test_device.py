"""The ``device`` setting on real Tool Delivery runs: ``cpu`` and ``auto`` train the CPU curve
bit for bit, ``cuda`` without a GPU is a one-line error, checkpoints hold CPU tensors and load
on the CPU — and, where a GPU exists, a run trained on it loads and resumes on the CPU."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import torch

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.policy import draw_multinomial

CUDA = torch.cuda.is_available()
METHODS = {
    "async": ["ppo.epochs=2"],
    "async-ar": ["ppo.epochs=2"],
    "mac-dqn": ["dqn.learning_starts=60", "dqn.train_every=20"],
}
TINY = [
    "--total-samples",
    "240",
    "batch_ticks=60",
    "num_envs=2",
    "checkpoint_every=2",
    "env.max_ticks=60",
    "progress=false",
    "video=false",
    "eval_episodes=0",
    "plot=false",
]


def _train(run_dir: Path, method: str, *extra: str) -> Path:
    argv = ["--method", method, *TINY, *METHODS[method], *extra, "--run-dir", str(run_dir)]
    assert train_main(argv) == 0
    return run_dir


def _curve(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as handle:
        return [
            {k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in csv.DictReader(handle)
        ]


def _tensors(value):
    """Every tensor inside a loaded checkpoint (dicts, lists, tuples)."""
    if isinstance(value, torch.Tensor):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _tensors(item)
    elif isinstance(value, list | tuple):
        for item in value:
            yield from _tensors(item)


def _saved_devices(path: Path) -> set[str]:
    """The devices of a checkpoint's tensors as stored (no ``map_location``)."""
    return {t.device.type for t in _tensors(torch.load(path, weights_only=True))}


def _acts(run_dir: Path, device: str) -> None:
    """``load_trained`` on ``device`` rebuilds a policy there that acts, greedy and sampled."""
    trained = load_trained(run_dir, device=device)
    assert {p.device.type for p in trained.policy.parameters()} == {device}
    assert trained.config.device == device
    env = trained.make_env(0)
    try:
        point = env.reset(seed=0)
        for greedy in (True, False):
            joint = trained.actor(greedy=greedy, seed=0)(point)
            assert joint.shape == (len(trained.policy.option_counts),)
    finally:
        env.close()


@pytest.fixture(scope="module")
def cpu_runs(tmp_path_factory) -> dict[tuple[str, str], Path]:
    """One tiny run per method and per device setting that lands on the CPU here."""
    if CUDA:
        pytest.skip("device=auto is cuda on this machine, whose rounding differs from the CPU's")
    root = tmp_path_factory.mktemp("device")
    return {
        (method, device): _train(root / f"{method}-{device}", method, f"device={device}")
        for method in METHODS
        for device in ("cpu", "auto")
    }


def test_the_setting_is_validated():
    with pytest.raises(ValueError, match=r"device must be one of \['auto', 'cpu', 'cuda'\]"):
        TrainConfig(device="gpu").resolved()
    assert TrainConfig().resolved().device == ("cuda" if CUDA else "cpu")


@pytest.mark.parametrize("method", METHODS)
def test_cpu_and_auto_train_the_same_curve_on_the_cpu(cpu_runs, method):
    cpu, auto = cpu_runs[method, "cpu"], cpu_runs[method, "auto"]
    assert _curve(cpu) == _curve(auto) and len(_curve(cpu)) == 4
    # auto is saved resolved: config.json says where the run computed.
    for run in (cpu, auto):
        assert json.loads((run / "config.json").read_text())["device"] == "cpu"


@pytest.mark.parametrize("method", METHODS)
def test_checkpoints_hold_cpu_tensors_and_load_on_the_cpu(cpu_runs, method):
    run = cpu_runs[method, "cpu"]
    for name in ("checkpoint.pt", "final.pt"):
        assert _saved_devices(run / name) == {"cpu"}
    _acts(run, "cpu")


def test_draws_on_the_cpu_are_torch_multinomials():
    """What keeps a CPU run's acting bit-identical: the device-aware draw is the plain one."""
    weights = torch.rand(5, 7)
    ours = draw_multinomial(weights, torch.Generator().manual_seed(3))
    plain = torch.multinomial(weights, 1, generator=torch.Generator().manual_seed(3)).squeeze(-1)
    assert torch.equal(ours, plain)


@pytest.mark.skipif(CUDA, reason="this machine has a GPU")
def test_cuda_without_a_gpu_is_a_one_line_error(tmp_path, user_error):
    run_dir = tmp_path / "run"
    argv = ["--method", "async", *TINY, "device=cuda", "--run-dir", str(run_dir)]
    user_error(train_main, argv, r"error: device=cuda, but torch\.cuda\.is_available\(\) is false")
    assert not run_dir.exists()


@pytest.mark.skipif(CUDA, reason="this machine has a GPU")
def test_eval_device(cpu_runs, user_error, capsys):
    run = str(cpu_runs["async", "cpu"])
    assert eval_main(["evaluate", "--checkpoint", run, "--episodes", "1", "--device", "cpu"]) == 0
    assert "options chosen" in capsys.readouterr().out
    argv = ["evaluate", "--checkpoint", run, "--episodes", "1", "--device", "cuda"]
    user_error(eval_main, argv, r"error: device=cuda, but torch\.cuda\.is_available\(\) is false")


@pytest.mark.skipif(not CUDA, reason="needs a CUDA GPU")
@pytest.mark.parametrize("method", METHODS)
def test_a_cuda_run_loads_and_resumes_on_the_cpu(tmp_path, method):
    run = _train(tmp_path / "run", method, "device=cuda")
    assert json.loads((run / "config.json").read_text())["device"] == "cuda"
    for name in ("checkpoint.pt", "final.pt"):
        assert _saved_devices(run / name) == {"cpu"}
    _acts(run, "cpu")
    _acts(run, "cuda")
    # The device is resumable: the run continues on the CPU from its cuda checkpoint.
    argv = ["--method", method, *TINY, *METHODS[method], "--run-dir", str(run)]
    argv[argv.index("240")] = "360"
    assert train_main([*argv, "device=cpu", "--resume"]) == 0
    assert json.loads((run / "config.json").read_text())["device"] == "cpu"
    assert len(_curve(run)) == 6
