"""The ``train`` command line on the real tasks: every method, resume after a kill, bad input."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from maopg.learner import CheckpointError, load_checkpoint
from train.__main__ import main, parse_args
from train.config import METHODS, TASK_DEFAULTS, TrainConfig, parse_overrides
from train.run_log import COLUMNS, TIMING_COLUMNS

REPO = Path(__file__).resolve().parents[1]
TINY = ["batch_ticks=60", "num_envs=2", "epochs=2", "progress=false", "checkpoint_every=2"]


def _rows(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as handle:
        return list(csv.DictReader(handle))


def _deterministic(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]


def test_overrides_are_typed_and_checked():
    values = parse_overrides(
        ["epochs=5", "lr=1e-3", "images=false", "total_samples=2_000", "env.max_ticks=50"]
    )
    assert values == {
        "epochs": 5,
        "lr": 1e-3,
        "images": False,
        "total_samples": 2000,
        "env_overrides": {"max_ticks": 50},
    }
    with pytest.raises(ValueError, match="unknown config key 'epoch'"):
        parse_overrides(["epoch=5"])
    with pytest.raises(ValueError, match="expected int"):
        parse_overrides(["epochs=many"])
    config, _ = parse_args(["--method", "sync-wait", "--seed", "3", "discount=option"])
    resolved = config.resolved()
    assert (resolved.strategy, resolved.policy_kind) == ("all", "centralized")
    assert resolved.batch_ticks == 200 and resolved.discount == "option"
    assert resolved.run_dir == os.path.join("runs", "tool_delivery", "sync-wait", "seed3")
    with pytest.raises(ValueError, match="unknown method"):
        TrainConfig(method="nope").resolved()


@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize("task", sorted(TASK_DEFAULTS))
def test_every_method_trains_a_tiny_budget(tmp_path, task, method):
    run_dir = tmp_path / method
    task = ["--task", task, "--method", method, "--seed", "0"]
    main([*task, "--total-samples", "120", "--run-dir", str(run_dir), *TINY])
    rows = _rows(run_dir)
    assert len(rows) >= 2 and list(rows[0]) == list(COLUMNS)
    assert int(rows[-1]["samples"]) >= 120
    for row in rows:
        assert int(row["option_steps"]) > 0
        assert float(row["samples_per_s"]) > 0
        assert float(row["entropy"]) >= 0
    for name in ("config.json", "checkpoint.pt", "final.pt", "learning_curve.png"):
        assert (run_dir / name).is_file(), name
    assert any((run_dir / "tb").iterdir())
    final = load_checkpoint(run_dir / "final.pt")
    assert final["config"]["method"] == method
    assert final["samples"] == int(rows[-1]["samples"])


def test_kill_and_resume_reproduces_the_uninterrupted_run(tmp_path):
    common = ["--method", "async", "--seed", "5", "--total-samples", "1200", *TINY]
    reference = tmp_path / "reference"
    main([*common, "--run-dir", str(reference)])

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
    assert not (killed / "final.pt").exists()

    main(["--resume", "--run-dir", str(killed), "progress=false"])
    assert _deterministic(_rows(killed)) == _deterministic(_rows(reference))


def test_worker_processes_give_the_same_curve_as_in_process(tmp_path):
    common = ["--seed", "2", "--total-samples", "240", *TINY]
    main([*common, "--run-dir", str(tmp_path / "serial"), "num_workers=0"])
    main([*common, "--run-dir", str(tmp_path / "workers"), "num_workers=2"])
    serial = _deterministic(_rows(tmp_path / "serial"))
    assert serial == _deterministic(_rows(tmp_path / "workers"))


def test_existing_run_needs_resume_and_corrupt_checkpoint_is_named(tmp_path):
    run_dir = tmp_path / "run"
    args = ["--total-samples", "60", "--run-dir", str(run_dir), *TINY]
    main(args)
    with pytest.raises(FileExistsError, match="--resume"):
        main(args)
    checkpoint = run_dir / "checkpoint.pt"
    checkpoint.write_bytes(checkpoint.read_bytes()[:100])
    with pytest.raises(CheckpointError, match=str(checkpoint)):
        main(["--resume", "--run-dir", str(run_dir), "--total-samples", "200"])
    with pytest.raises(ValueError, match="seed"):
        main(["--resume", "--run-dir", str(run_dir), "--seed", "9"])
