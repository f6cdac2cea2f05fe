import random

import numpy as np
import pytest
import torch

from maopg.learner import (
    CheckpointError,
    capture_global_rng,
    load_checkpoint,
    remove_stale_temporaries,
    restore_global_rng,
    save_checkpoint,
)
from maopg.learner.checkpoint import CHECKSUM_KEY, TENSORS_CHECKSUM_KEY, tensors_digest


def test_round_trip_restores_tensors_counters_and_rng_streams(tmp_path):
    torch.manual_seed(1)
    np.random.seed(2)
    random.seed(3)
    gen = torch.Generator().manual_seed(4)
    state = {
        "iteration": 7,
        "weights": {"w": torch.randn(3, 2)},
        "config": {"task": "tool_delivery", "env_overrides": {"max_ticks": 50}},
        "gen": gen.get_state(),
        "global_rng": capture_global_rng(),
    }
    path = save_checkpoint(tmp_path / "ck.pt", state)
    expected = (torch.rand(3), np.random.rand(3), random.random(), torch.rand(2, generator=gen))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ck.pt"]  # no temporary left behind

    loaded = load_checkpoint(path, required=("iteration", "weights"))
    restore_global_rng(loaded["global_rng"])
    gen2 = torch.Generator()
    gen2.set_state(loaded["gen"])
    again = (torch.rand(3), np.random.rand(3), random.random(), torch.rand(2, generator=gen2))
    torch.testing.assert_close(again[0], expected[0])
    np.testing.assert_array_equal(again[1], expected[1])
    assert again[2] == expected[2]
    torch.testing.assert_close(again[3], expected[3])
    torch.testing.assert_close(loaded["weights"]["w"], state["weights"]["w"])
    assert loaded["config"] == state["config"]


def test_overwrite_replaces_the_old_checkpoint(tmp_path):
    path = tmp_path / "ck.pt"
    save_checkpoint(path, {"iteration": 1})
    save_checkpoint(path, {"iteration": 2})
    assert load_checkpoint(path)["iteration"] == 2


@pytest.mark.parametrize("damage", ["truncate", "garbage", "empty"])
def test_corrupt_checkpoint_names_the_file(tmp_path, damage):
    path = tmp_path / "ck.pt"
    save_checkpoint(path, {"iteration": 1, "w": torch.randn(100)})
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        path.write_bytes(b"not a checkpoint at all" * 10)
    else:
        path.write_bytes(b"")
    with pytest.raises(CheckpointError, match=str(path)):
        load_checkpoint(path)


def test_missing_file_and_missing_entries(tmp_path):
    with pytest.raises(CheckpointError, match="does not exist"):
        load_checkpoint(tmp_path / "nope.pt")
    path = save_checkpoint(tmp_path / "ck.pt", {"iteration": 1})
    with pytest.raises(CheckpointError, match=r"lacks the entries \['policy'\]"):
        load_checkpoint(path, required=("iteration", "policy"))


def test_code_carrying_pickle_is_refused(tmp_path):
    path = tmp_path / "evil.pt"
    torch.save({"obj": _Custom()}, path)
    with pytest.raises(CheckpointError, match=str(path)):
        load_checkpoint(path)


class _Custom:
    pass


def test_flipped_tensor_bytes_are_caught_and_old_checkpoints_load_where_accepted(tmp_path):
    weights = {"w": torch.arange(4096, dtype=torch.float32), "n": torch.tensor(3)}
    path = save_checkpoint(tmp_path / "ck.pt", {"weights": weights, "iteration": 1})
    assert set(load_checkpoint(path)) == {"weights", "iteration"}  # the checksum is ours
    data = bytearray(path.read_bytes())
    at = data.find(torch.arange(4096, dtype=torch.float32)[2000:2002].numpy().tobytes())
    assert at > 0
    data[at] ^= 0x01  # one bit of the weights, not of the zip's or the pickle's bookkeeping
    path.write_bytes(bytes(data))
    with pytest.raises(CheckpointError, match=rf"checkpoint {path} is corrupt or was edited"):
        load_checkpoint(path)

    # earlier formats: a checksum of the tensors alone, or none; by default neither loads
    earlier = {"weights": weights, TENSORS_CHECKSUM_KEY: tensors_digest({"weights": weights})}
    for stored, accepted in ((earlier, TENSORS_CHECKSUM_KEY), ({"weights": weights}, None)):
        torch.save(stored, path)
        with pytest.raises(CheckpointError, match=rf"checkpoint {path} lacks the checksum"):
            load_checkpoint(path)
        loaded = load_checkpoint(path, accepts=lambda state, kind=accepted: (kind,))
        torch.testing.assert_close(loaded["weights"]["w"], weights["w"])
    earlier["weights"] = {"w": weights["w"] + 1}  # the tensors-only checksum still tells
    torch.save(earlier, path)
    with pytest.raises(CheckpointError, match="its tensors do not match"):
        load_checkpoint(path, accepts=lambda state: (TENSORS_CHECKSUM_KEY,))


def test_the_checksum_covers_every_entry_not_only_the_tensors(tmp_path):
    """An edited number, string, container or type (``1`` for ``1.0``, a tuple for a list):
    each is caught; the same entries in another order are not an edit."""
    state = {"config": {"method": "async", "lr": 1.0, "sizes": [64, 64]}, "w": torch.ones(2)}
    path = save_checkpoint(tmp_path / "ck.pt", state)
    stored = torch.load(path, weights_only=True)
    config = dict(reversed(stored["config"].items()))
    torch.save({"w": stored["w"], CHECKSUM_KEY: stored[CHECKSUM_KEY], "config": config}, path)
    assert load_checkpoint(path)["config"] == state["config"]
    for edit in ({"method": "sync-cut"}, {"lr": 1}, {"sizes": (64, 64)}, {"sizes": [64]}):
        torch.save({**stored, "config": {**stored["config"], **edit}}, path)
        with pytest.raises(CheckpointError, match="its entries do not match"):
            load_checkpoint(path)


def test_only_our_own_stale_temporaries_are_removed(tmp_path):
    path = tmp_path / "checkpoint.pt"
    ours = [tmp_path / ".checkpoint.pt.a1_b2c3d.tmp", tmp_path / ".checkpoint.pt.zzzzzzzz.tmp"]
    others = [
        tmp_path / ".checkpoint.pt.tmp",
        tmp_path / ".checkpoint.pt.toolongname.tmp",
        tmp_path / ".final.pt.a1_b2c3d.tmp",
        tmp_path / "checkpoint.pt.a1_b2c3d.tmp",
    ]
    for file in (*ours, *others):
        file.write_bytes(b"x")
    assert sorted(remove_stale_temporaries(path)) == sorted(ours)
    assert all(file.exists() for file in others) and not any(file.exists() for file in ours)
