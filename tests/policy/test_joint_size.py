"""Networks with one output per joint option refuse a team too large for the memory they would
train in, with the joint size, before anything is allocated or written."""

from __future__ import annotations

import pytest
import torch

from maopg.experiment.train_cli import main
from maopg.policy.joint_size import (
    building_for,
    joint_head_bytes,
    machine_memory,
    require_joint_head_fits,
    training_memory,
)

TEAM_OF_EIGHT = ["env.turtlebots=6", "env.fetches=2", "env.humans=3"]


@pytest.mark.parametrize("method", ["async", "sync-cut", "partial", "mac-dqn"])
def test_a_product_method_refuses_a_team_of_eight_from_the_command_line(
    tmp_path, user_error, method
):
    run_dir = tmp_path / "run"
    argv = ["--method", method, *TEAM_OF_EIGHT, "--total-samples", "100", "--run-dir", str(run_dir)]
    err = user_error(main, argv, r"8 agents have 7\^6·13·10 = 15,294,370 joint options")
    assert "async-ar" in err and len(err.strip().splitlines()) == 1, err
    assert not run_dir.exists()


def test_the_device_being_built_for_sets_the_limit():
    """Within ``building_for`` the default limit is that device's memory; outside it, the
    machine's again."""
    counts, size = (6,) * 7 + (8,), {"hidden": 128, "copies": 4, "rows": 1}
    need = joint_head_bytes(counts, **size)
    host = machine_memory()
    assert training_memory("cpu") == (host, "this machine's")
    with building_for("cpu"):
        if need > host // 2:
            with pytest.raises(ValueError, match="this machine's"):
                require_joint_head_fits(counts, **size, who="p", instead="-")
        else:
            require_joint_head_fits(counts, **size, who="p", instead="-")
    # an explicit memory wins over the device's
    with building_for("cpu"), pytest.raises(ValueError, match=r"6\^7·8 = 2,239,488"):
        require_joint_head_fits(counts, **size, who="p", instead="-", memory=need)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_on_a_gpu_the_limit_is_the_lesser_of_its_memory_and_the_machines():
    gpu = torch.cuda.get_device_properties(0).total_memory
    memory, where = training_memory("cuda")
    assert memory == min(machine_memory(), gpu)
    assert ("GPU" in where) == (gpu <= machine_memory())
