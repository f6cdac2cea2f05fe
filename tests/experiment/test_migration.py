"""Configs and checkpoints of earlier releases load through one step
(maopg.experiment.run.migration): every committed run directory, a schema-1 config and a schema-1
checkpoint that resumes bit for bit; a schema from the future is one clear line."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
import torch

from maopg.experiment.cli.train_cli import main
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.config_file import read_config_file
from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.experiment.run.migration import (
    CHECKPOINT_SCHEMA,
    CONFIG_SCHEMA,
    FLAT_PPO_KEYS,
    SCHEMA_KEY,
    migrate_checkpoint,
    migrate_config,
    read_checkpoint,
)
from maopg.learner import CheckpointError, MacDQNConfig, PPOConfig, load_checkpoint
from maopg.learner.checkpoint import (
    CHECKSUM_KEY,
    TENSORS_CHECKSUM_KEY,
    save_checkpoint,
    state_digest,
    tensors_digest,
)

RESULTS = Path(__file__).resolve().parents[2] / "results"
TINY = ["--task", "tool_delivery", "batch_ticks=60", "num_envs=2", "checkpoint_every=1"]
TINY += ["env.max_ticks=40", "video=false", "eval_episodes=0", "plot=false", "ppo.epochs=2"]


def test_every_committed_config_loads_and_resolves():
    """151 saved configs of several releases: flat MAPPO keys, a dqn section in every
    method's config, sections (schema 1 all, without the key)."""
    paths = sorted(RESULTS.rglob("config.json"))
    assert len(paths) >= 100
    for path in paths:
        TrainConfig.load(path).resolved()


def test_the_committed_checkpoints_load():
    """Every committed Tool Delivery policy and Water Filling's recurrent one (schema 1); the
    other Water Filling policies' checkpoints are of the same schema, and each study's
    evaluation loads them all (a camera environment each: too slow for this test)."""
    paths = sorted(RESULTS.rglob("tool_delivery/*/seed0/final.pt"))
    paths.append(RESULTS / "memory/runs/water_filling/async-rnn/seed0/final.pt")
    assert len(paths) >= 10
    for path in paths:
        trained = load_trained(path)
        assert trained.samples > 0


def test_a_schema_1_config_moves_flat_keys_into_its_section():
    legacy = {**TrainConfig().to_dict(), "epochs": 7, "discount": "option", "dqn": {"lr": 1.0}}
    del legacy["ppo"]
    assert TrainConfig.from_dict(migrate_config(legacy)).learner == PPOConfig(
        epochs=7, discount="option"
    )
    dqn = {**legacy, "method": "mac-dqn"}  # flat MAPPO keys meant nothing to Mac-DQN
    assert TrainConfig.from_dict(migrate_config(dqn)).learner == MacDQNConfig(lr=1.0)
    current = TrainConfig().to_dict()  # sections already: read as it is
    assert migrate_config(current) == current


def test_a_saved_config_records_its_schema_and_a_future_one_is_refused(tmp_path):
    path = tmp_path / "config.json"
    TrainConfig(task="tool_delivery").save(path)
    assert json.loads(path.read_text())[SCHEMA_KEY] == CONFIG_SCHEMA
    assert TrainConfig.load(path).to_dict() == TrainConfig(task="tool_delivery").to_dict()
    path.write_text(json.dumps({SCHEMA_KEY: CONFIG_SCHEMA + 1, "task": "tool_delivery"}))
    with pytest.raises(ValueError, match=rf"config\.json: config schema {CONFIG_SCHEMA + 1}: "):
        read_config_file(path)
    with pytest.raises(ValueError, match=f"checkpoint schema {CHECKPOINT_SCHEMA + 1}"):
        migrate_checkpoint({SCHEMA_KEY: CHECKPOINT_SCHEMA + 1})


def _rows(run_dir: Path) -> list[dict[str, str]]:
    with (run_dir / "metrics.csv").open() as handle:
        return [
            {k: v for k, v in row.items() if k not in TIMING_COLUMNS}
            for row in csv.DictReader(handle)
        ]


def test_a_schema_1_checkpoint_resumes_bit_for_bit(tmp_path):
    """A checkpoint as releases before the schema wrote it — no schema entry, the environments'
    state under ``sampler``, a config with flat MAPPO keys — resumes as an uninterrupted run."""
    whole, old = tmp_path / "whole", tmp_path / "old"
    common = ["--seed", "4", *TINY]
    assert main([*common, "--total-samples", "240", "--run-dir", str(whole)]) == 0
    assert main([*common, "--total-samples", "120", "--run-dir", str(old)]) == 0
    state = load_checkpoint(old / "checkpoint.pt")
    assert state.pop(SCHEMA_KEY) == CHECKPOINT_SCHEMA
    state["sampler"] = state.pop("envs")
    ppo = state["config"].pop("ppo")  # flat, and only the keys releases of that time had
    state["config"] = {**state["config"], **{k: v for k, v in ppo.items() if k in FLAT_PPO_KEYS}}
    save_checkpoint(old / "checkpoint.pt", state)
    (old / "done.json").unlink()
    assert main(["--resume", "--run-dir", str(old), "--total-samples", "240"]) == 0
    assert _rows(old) == _rows(whole)
    with pytest.raises(CheckpointError, match="lacks the entries"):
        load_trained(save_checkpoint(tmp_path / "bare.pt", {"iteration": 1}))


def test_the_checksum_a_checkpoint_must_carry_follows_from_its_schema(tmp_path):
    """From schema 4 the one over every entry; schemas 2 and 3 checksummed their tensors
    alone; only schema 1, whose earliest checkpoints had none, loads without one."""
    path = tmp_path / "ck.pt"
    entries = {"iteration": 1, "w": torch.ones(3)}
    for schema, checksum, loads in [
        (CHECKPOINT_SCHEMA, CHECKSUM_KEY, True),
        (CHECKPOINT_SCHEMA, TENSORS_CHECKSUM_KEY, False),
        (3, TENSORS_CHECKSUM_KEY, True),
        (2, None, False),
        (1, TENSORS_CHECKSUM_KEY, True),
        (1, None, True),
    ]:
        state = {**entries, **({SCHEMA_KEY: schema} if schema > 1 else {})}
        digests = {CHECKSUM_KEY: state_digest, TENSORS_CHECKSUM_KEY: tensors_digest}
        torch.save({**state, **({checksum: digests[checksum](state)} if checksum else {})}, path)
        if loads:
            assert read_checkpoint(path)["iteration"] == 1
        else:
            with pytest.raises(CheckpointError, match=f"checkpoint {path} lacks the checksum"):
                read_checkpoint(path)
