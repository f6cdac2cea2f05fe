"""The ``precision`` setting: ``bf16`` runs the CNNs (only them) in bfloat16 and keeps everything
else, the weights and their gradients in float32; a ``bf16`` run is deterministic and resumes
exactly, and an evaluation acts in the precision the run trained in."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import torch

from maopg.env import make_env
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.experiment.training import trainer
from maopg.experiment.training.trainer import build_learner
from maopg.policy import PRECISIONS, CentralCritic, NatureCNN, ObsBatch, set_precision

TINY = [
    "--images",
    "image_size=36",
    "batch_ticks=40",
    "num_envs=2",
    "checkpoint_every=1",
    "env.max_ticks=60",
    "ppo.epochs=2",
    "progress=false",
    "video=false",
    "eval_episodes=0",
    "plot=false",
]


def _curve(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as handle:
        return [
            {k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in csv.DictReader(handle)
        ]


def _train(run_dir: Path, samples: int, *extra: str) -> list[dict[str, str]]:
    argv = [*TINY, "--total-samples", str(samples), *extra, "--run-dir", str(run_dir)]
    assert train_main(argv) == 0
    return _curve(run_dir)


def test_bf16_computes_the_cnn_in_bfloat16_and_keeps_float32_outside() -> None:
    torch.manual_seed(0)
    cnn = NatureCNN((36, 36, 3))
    images = torch.randint(0, 256, (8, 36, 36, 3), dtype=torch.uint8)
    reference = cnn(images)
    reference.square().sum().backward()
    grads = [p.grad.clone() for p in cnn.parameters()]
    cnn.zero_grad()
    set_precision(cnn, "bf16")
    seen: list[torch.dtype] = []
    hook = cnn.convs[0].register_forward_hook(lambda _m, _i, out: seen.append(out.dtype))
    features = cnn(images)
    hook.remove()
    assert seen == [torch.bfloat16] and features.dtype == torch.float32
    features.square().sum().backward()
    # bfloat16 keeps 8 bits of mantissa: features and gradients agree to about 1%.
    assert torch.allclose(features, reference, rtol=0.05, atol=0.05 * reference.abs().max().item())
    for param, grad in zip(cnn.parameters(), grads, strict=True):
        assert param.dtype == torch.float32 and param.grad.dtype == torch.float32
        cosine = torch.nn.functional.cosine_similarity(param.grad.flatten(), grad.flatten(), dim=0)
        assert cosine > 0.99
    set_precision(cnn, "fp32")
    assert torch.equal(cnn(images), reference.detach())


def test_set_precision_reaches_every_cnn_and_refuses_an_unknown_precision() -> None:
    env = make_env("tool_delivery", "continue", images=True, image_size=36)
    try:
        critic = CentralCritic(env.spec)
        obs = ObsBatch.from_decision_points([env.reset(seed=0)])
    finally:
        env.close()
    cnns = [m for m in critic.modules() if isinstance(m, NatureCNN)]
    assert cnns
    set_precision(critic, "bf16")
    assert {c.compute_dtype for c in cnns} == {PRECISIONS["bf16"]}
    assert critic(obs).dtype == torch.float32
    with pytest.raises(ValueError, match=r"precision must be one of \['fp32', 'bf16'\]"):
        set_precision(critic, "fp16")


def _cnn_dtypes(module: torch.nn.Module) -> set[torch.dtype]:
    return {m.compute_dtype for m in module.modules() if isinstance(m, NatureCNN)}


@pytest.mark.parametrize("method", ["async", "partial", "mac-dqn"])
def test_every_learner_sets_the_precision_of_every_network_it_holds(method: str) -> None:
    """The policy (any method's), MAPPO's critic, Mac-DQN's online and target Q-networks."""
    config = TrainConfig(
        task="tool_delivery",
        method=method,
        images=True,
        image_size=36,
        hidden=16,
        layers=1,
        precision="bf16",
    ).resolved()
    env = config.env().make(0)
    try:
        learner = build_learner(config, env.spec, torch.Generator(), torch.Generator())
    finally:
        env.close()
    networks = [learner.policy]
    networks += [learner.critic] if method != "mac-dqn" else [learner.dqn.target]  # type: ignore[attr-defined]
    for network in networks:
        assert _cnn_dtypes(network) == {torch.bfloat16}, type(network).__name__


def test_a_bf16_run_is_deterministic_resumes_exactly_and_evaluates_in_bf16(
    tmp_path: Path,
) -> None:
    whole = _train(tmp_path / "whole", 120, "precision=bf16")
    first = _train(tmp_path / "split", 40, "precision=bf16")
    resumed = _train(tmp_path / "split", 120, "precision=bf16", "--resume")
    assert len(whole) == 3 and first == whole[:1] and resumed == whole
    fp32 = _train(tmp_path / "fp32", 120)
    assert fp32 != whole  # the setting changes what is computed
    trained = load_trained(tmp_path / "whole")
    assert trained.config.precision == "bf16"
    assert _cnn_dtypes(trained.policy) == {torch.bfloat16}


def test_a_resume_keeps_the_precision(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Unsaid, a resumed run keeps its precision; another one is refused before anything runs."""
    run = tmp_path / "run"
    _train(run, 40, "precision=bf16")
    _train(run, 80, "--resume")
    assert json.loads((run / "config.json").read_text())["precision"] == "bf16"
    capsys.readouterr()
    argv = [*TINY, "--total-samples", "120", "--resume", "precision=fp32", "--run-dir", str(run)]
    assert train_main(argv) == 2
    err = capsys.readouterr().err
    assert "precision" in err and "Traceback" not in err
    assert len(_curve(run)) == 2


def test_bf16_where_it_is_slow_is_said_at_the_start(
    tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """More than one torch thread, or a CPU without bf16 instructions: one note each."""
    monkeypatch.setattr(trainer, "bf16_instructions", lambda: [])
    threads = torch.get_num_threads()
    try:
        _train(tmp_path / "run", 40, "precision=bf16", "torch_threads=2")
    finally:
        torch.set_num_threads(threads)
    err = capsys.readouterr().err
    assert "precision=bf16 with 2 torch threads" in err
    assert "precision=bf16 on a CPU without bf16 instructions" in err
    _train(tmp_path / "fp32", 40, "torch_threads=2")
    assert "precision=bf16" not in capsys.readouterr().err
