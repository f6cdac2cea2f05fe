"""``logger=wandb`` (issue #17): W&B gets what TensorBoard gets, and a resumed run sends no row
twice and loses none. Real W&B in offline mode; its run files are read back as written."""

from __future__ import annotations

import csv
import json
import os
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import pytest

from maopg.experiment.cli.train_cli import main
from maopg.experiment.run.directory import TIMING_COLUMNS
from maopg.experiment.training import trainer

pytest.importorskip("wandb")
from wandb.proto import wandb_internal_pb2

RUN = [
    "--seed",
    "1",
    "batch_ticks=60",
    "num_envs=2",
    "progress=false",
    "plot=false",
    "ppo.epochs=2",
    "checkpoint_every=2",
    "logger=wandb",
    "wandb.mode=offline",
]
QUIET = ["video=false", "eval_episodes=0"]


@pytest.fixture(autouse=True)
def _wandb_home(tmp_path, monkeypatch):
    """W&B's settings, cache and credentials in the test's folder, not the user's."""
    for name in ("WANDB_CONFIG_DIR", "WANDB_CACHE_DIR", "WANDB_DATA_DIR"):
        monkeypatch.setenv(name, str(tmp_path / "wandb-home"))


def _records(path: Path):
    """The records of a ``.wandb`` file: W&B's LevelDB-style log (a 7-byte header, then 32 KiB
    blocks of chunks, each ``crc32 | length | kind`` + payload; kind 1 whole, 2-4 first,
    middle, last), each record a ``wandb_internal_pb2.Record``.

    The file may be read while W&B's service process is still writing it (``_run_files`` polls
    for the exit record), so the records end at the first chunk not yet wholly written: one
    that runs past the end of the file or whose checksum (CRC-32 of kind byte and payload)
    does not match yet. CI once read a half-written chunk as a corrupt record."""
    data, block = path.read_bytes(), 32 * 1024
    assert data[:4] == b":W&B"
    position, payload = 7, b""
    while position + 7 <= len(data):
        left = block - position % block
        crc, length, kind = struct.unpack("<IHB", data[position : position + 7])
        if left < 7 or (length == 0 and kind == 0):  # block padding
            position += left
            continue
        chunk = data[position + 7 : position + 7 + length]
        if len(chunk) < length or zlib.crc32(chunk, zlib.crc32(bytes([kind]))) != crc:
            return  # the tail W&B is still writing
        payload += chunk
        position += 7 + length
        if kind in (1, 4):
            record = wandb_internal_pb2.Record()
            record.ParseFromString(payload)
            payload = b""
            yield record


def _run_files(run_dir: Path) -> list[Path]:
    """The run's offline W&B files (one per start of the run), each once it holds its exit
    record: W&B's service process writes a run's last records after ``finish()`` has returned,
    which on a loaded machine can take a moment (the suite saw an exit record missing once, and
    a resumed run's last history rows once)."""
    deadline = time.monotonic() + 30.0
    while True:
        paths = sorted(run_dir.glob("wandb/offline-run-*/run-*.wandb"))
        finished = all(
            any(r.WhichOneof("record_type") == "exit" for r in _records(path)) for path in paths
        )
        if finished or time.monotonic() > deadline:
            return paths
        time.sleep(0.2)


def _history(run_dir: Path) -> list[dict[str, object]]:
    """Every history row of every start of the run (W&B writes one folder per start)."""
    rows = []
    for path in _run_files(run_dir):
        for record in _records(path):
            if record.WhichOneof("record_type") == "history":
                rows.append(
                    {
                        item.key or "/".join(item.nested_key): json.loads(item.value_json)
                        for item in record.history.item
                    }
                )
    return rows


def _summary_and_config(run_dir: Path) -> tuple[dict[str, object], dict[str, object]]:
    summary, config = {}, {}
    for path in _run_files(run_dir):
        for record in _records(path):
            kind = record.WhichOneof("record_type")
            if kind == "summary":
                for item in record.summary.update:
                    summary[item.key or "/".join(item.nested_key)] = json.loads(item.value_json)
            elif kind in ("run", "config"):  # the settings come with the run record
                updates = record.run.config.update if kind == "run" else record.config.update
                for item in updates:
                    config[item.key or "/".join(item.nested_key)] = json.loads(item.value_json)
    return summary, config


def _train_rows(run_dir: Path) -> dict[int, dict[str, object]]:
    """The ``train/*`` values of each W&B step, timing columns left out; a step sent twice
    fails the test."""
    rows: dict[int, dict[str, object]] = {}
    for row in _history(run_dir):
        train = {
            k: v
            for k, v in row.items()
            if k.startswith(("train/", "options/"))
            and k.removeprefix("train/") not in TIMING_COLUMNS
        }
        if train:
            assert row["_step"] not in rows, f"step {row['_step']} sent twice"
            rows[row["_step"]] = train
    return rows


def test_wandb_gets_the_rows_settings_evaluation_and_video(tmp_path):
    run_dir = tmp_path / "run"
    argv = [*RUN, "--total-samples", "120", "--run-dir", str(run_dir), "eval_episodes=1"]
    assert main([*argv, "env.max_ticks=40"]) == 0

    with (run_dir / "metrics.csv").open() as handle:
        csv_rows = list(csv.DictReader(handle))
    rows = _train_rows(run_dir)
    assert sorted(rows) == [int(r["samples"]) for r in csv_rows]
    for csv_row in csv_rows:
        sent = rows[int(csv_row["samples"])]
        assert sent["train/episodes"] == int(csv_row["episodes"])
        assert sent["train/policy_loss"] == pytest.approx(float(csv_row["policy_loss"]))
        assert any(k.startswith("options/fetch/") for k in sent)
    summary, config = _summary_and_config(run_dir)
    assert set(summary) >= {"eval/return_greedy", "eval/return_sampled"}
    assert config["ppo.epochs"] == 2 and config["task"] == "tool_delivery"
    (video,) = [row for row in _history(run_dir) if "rollout/_type" in row]
    assert video["rollout/_type"] == "video-file" and video["_step"] == max(rows)
    assert list(run_dir.glob("wandb/offline-run-*/files/media/videos/*.mp4"))


def test_a_resumed_run_sends_every_row_once(tmp_path):
    """Killed after a checkpoint (its later rows already sent, then the checkpoint set back)
    and resumed: W&B holds exactly the rows of the uninterrupted run, each once."""
    whole, killed, early = tmp_path / "whole", tmp_path / "killed", tmp_path / "early"
    assert main([*RUN, *QUIET, "--total-samples", "480", "--run-dir", str(whole)]) == 0
    assert main([*RUN, *QUIET, "--total-samples", "300", "--run-dir", str(killed)]) == 0
    assert main([*RUN, *QUIET, "--total-samples", "120", "--run-dir", str(early)]) == 0
    (killed / "checkpoint.pt").write_bytes((early / "checkpoint.pt").read_bytes())
    for name in ("done.json", "final.pt"):
        (killed / name).unlink()
    resume = ["--resume", "--run-dir", str(killed), "--total-samples", "480"]
    assert main([*resume, "eval_episodes=1"]) == 0

    assert len(list(killed.glob("wandb/offline-run-*"))) == 2
    expected, resumed = _train_rows(whole), _train_rows(killed)
    assert len(expected) >= 8 and sorted(resumed) == sorted(expected)
    for step, values in expected.items():
        assert resumed[step] == values, step
    ids = {json.loads((d / "wandb.json").read_text())["id"] for d in (whole, killed, early)}
    assert len(ids) == 3  # one W&B run per run directory, kept across its resumption
    assert "eval/return_greedy" in _summary_and_config(killed)[0]


def test_wandb_without_an_account_is_one_line_and_leaves_no_run(tmp_path):
    run_dir = tmp_path / "run"
    env = {k: v for k, v in os.environ.items() if not k.startswith("WANDB_")}
    env.update(HOME=str(tmp_path), WANDB_CONFIG_DIR=str(tmp_path / "wandb-home"))
    command = [sys.executable, "-m", "maopg.experiment.cli.train_cli", *RUN[:-1], *QUIET]
    done = subprocess.run(
        [*command, "--total-samples", "60", "--run-dir", str(run_dir)],
        env=env,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 2, done.stderr
    assert "logger=wandb: No API key configured" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr and not run_dir.exists()


def _exit_codes(run_dir: Path) -> list[int]:
    """The exit codes of the offline W&B runs in ``run_dir``, one per start of the run."""
    return [
        record.exit.exit_code
        for path in _run_files(run_dir)
        for record in _records(path)
        if record.WhichOneof("record_type") == "exit"
    ]


def test_a_run_whose_after_training_steps_fail_ends_its_wandb_run_failed(tmp_path, monkeypatch):
    """Training finished but its evaluation (or video, or plot) raised: W&B must not show the
    run as a success, and the run stays unfinished (no done.json) so a rerun repeats them."""

    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("the evaluation broke")

    monkeypatch.setattr(trainer, "after_training", broken)
    run_dir = tmp_path / "run"
    with pytest.raises(RuntimeError, match="the evaluation broke"):
        main([*RUN, *QUIET, "--total-samples", "60", "--run-dir", str(run_dir), "--debug"])
    assert _exit_codes(run_dir) == [1]
    assert not (run_dir / "done.json").exists()
    monkeypatch.undo()
    assert main([*RUN, *QUIET, "--total-samples", "60", "--run-dir", str(run_dir), "--resume"]) == 0
    assert _exit_codes(run_dir) == [1, 0]
