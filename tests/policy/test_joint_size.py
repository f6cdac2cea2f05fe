"""Networks with one output per joint option refuse a team too large for the memory they would
train in, with the joint size, before anything is allocated or written."""

from __future__ import annotations

import pytest
import torch

from maopg.experiment.cli.train_cli import main
from maopg.learner.mappo import PPOConfig, update_rows
from maopg.policy import joint_size
from maopg.policy.joint_size import (
    BuildTarget,
    joint_head_bytes,
    machine_memory,
    require_joint_head_fits,
    training_memory,
)

TEAM_OF_EIGHT = ["env.turtlebots=6", "env.fetches=2", "env.humans=3"]
GIB = 2**30


@pytest.mark.parametrize("method", ["async", "sync-cut", "partial", "mac-dqn"])
def test_a_product_method_refuses_a_team_of_eight_from_the_command_line(
    tmp_path, user_error, monkeypatch, method
):
    """On a 64 GiB machine (the refusal depends on the memory, so the test fixes it)."""
    monkeypatch.setattr(joint_size, "machine_memory", lambda: 64 * GIB)
    run_dir = tmp_path / "run"
    argv = ["--method", method, *TEAM_OF_EIGHT, "--total-samples", "100", "--run-dir", str(run_dir)]
    err = user_error(main, argv, r"8 agents have 7\^6·13·10 = 15,294,370 joint options")
    assert "half of this machine's 64 GiB" in err and "async-ar" in err
    assert len(err.strip().splitlines()) == 1, err
    assert not run_dir.exists()


def test_the_trainer_holds_heads_to_the_memory_of_the_device_it_builds_for(
    tmp_path, user_error, monkeypatch
):
    """The paper's Tool Delivery team (54 joint options) fits anywhere but on a device of a few
    hundred kilobytes: the trainer builds for the run's device (``BuildTarget.for_training``),
    whose memory and name the refusal gives, not the machine's."""
    monkeypatch.setattr(joint_size, "machine_memory", lambda: 1024 * GIB)
    monkeypatch.setattr(joint_size, "training_memory", lambda device: (2**18, "the tiny device's"))
    run_dir = tmp_path / "run"
    argv = ["--total-samples", "100", "--run-dir", str(run_dir)]
    user_error(main, argv, r"3\^2·6 = 54 joint options.*half of the tiny device's 0 GiB")
    assert not run_dir.exists()
    # a policy built to act (loading a checkpoint) is held to the machine's memory
    machine = BuildTarget.this_machine()
    assert machine == BuildTarget(1024 * GIB, "this machine's", batch_ticks=1)
    require_joint_head_fits(
        (3, 3, 6), hidden=128, copies=4, rows=600, who="p", instead="-", target=machine
    )


def test_an_update_holds_rows_for_the_runs_batch():
    """The product categorical's estimate counts one batch of the run's rows."""
    run = BuildTarget.for_training("cpu", batch_ticks=200)
    assert update_rows(PPOConfig(), BuildTarget.this_machine()) == 3  # to act: one row
    assert update_rows(PPOConfig(), run) == 600
    assert update_rows(PPOConfig(num_minibatches=2), run) == 300
    counts = (6,) * 7 + (8,)
    need = joint_head_bytes(counts, hidden=128, copies=4, rows=600)
    with pytest.raises(ValueError, match=r"6\^7·8 = 2,239,488"):
        require_joint_head_fits(
            counts,
            hidden=128,
            copies=4,
            rows=600,
            who="p",
            instead="-",
            target=BuildTarget(need, "a small machine's"),
        )


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_on_a_gpu_the_limit_is_the_lesser_of_its_memory_and_the_machines():
    gpu, host = torch.cuda.get_device_properties(0).total_memory, machine_memory()
    memory, where = training_memory("cuda")
    assert memory == (min(host, gpu) if host else gpu)
    assert where.startswith("the GPU's") == (memory == gpu and (not host or gpu <= host))
