"""One writer per run directory (maopg/experiment/run/lock.py): a second ``train`` on a busy
directory stops with one line and deletes nothing, a killed holder leaves no stale lock, and
grid invocations share out the cells of one grid (``--jobs``, or several at once) with the
same curves as one after another."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.run import lock as run_lock
from maopg.experiment.run.directory import CONFIG, DONE, TIMING_COLUMNS, read_metrics
from maopg.experiment.run.lock import RunDirBusy, RunDirLock, held_elsewhere
from maopg.experiment.studies.grid import BUSY, Cell, run_grid
from maopg.experiment.studies.results import reproduce

TINY = [
    "batch_ticks=60",
    "num_envs=2",
    "checkpoint_every=1",
    "env.max_ticks=40",
    "video=false",
    "eval_episodes=0",
    "plot=false",
    "progress=false",
    "ppo.epochs=2",
    "backend=threads",
]


def _train(run_dir: Path, *args: str) -> int:
    return train_main(["--seed", "1", "--run-dir", str(run_dir), *TINY, *args])


def _record(run_dir: Path) -> list[dict[str, str]]:
    """``metrics.csv`` without the columns that depend on the machine."""
    rows = read_metrics(run_dir / "metrics.csv")
    return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in rows]


def test_a_busy_run_directory_stops_a_second_train_and_loses_nothing(tmp_path, user_error):
    run_dir = tmp_path / "run"
    assert _train(run_dir, "--total-samples", "60") == 0
    before = {p.name: p.read_bytes() for p in run_dir.iterdir() if p.is_file()}
    with RunDirLock(run_dir) as lock:
        assert lock.held and held_elsewhere(run_dir)
        for extra in (["--resume", "--total-samples", "120"], ["--overwrite"], []):
            user_error(lambda argv: _train(run_dir, *argv), extra, r"in use: another process")
        assert {p.name: p.read_bytes() for p in run_dir.iterdir() if p.is_file()} == before
        with pytest.raises(RunDirBusy):
            RunDirLock(run_dir).acquire()
    assert not held_elsewhere(run_dir)  # released on exit
    assert _train(run_dir, "--resume", "--total-samples", "120") == 0
    assert int(_record(run_dir)[-1]["samples"]) >= 120
    # --overwrite empties the directory it holds, and the lock goes with the run, not before
    assert _train(run_dir, "--overwrite", "--total-samples", "60") == 0
    assert not held_elsewhere(run_dir) and (run_dir / DONE).exists()


def test_overwrite_keeps_the_locked_directory_and_no_flock_means_no_lock(tmp_path, monkeypatch):
    """``--overwrite`` empties the directory (the lock is on it, so it must not be replaced);
    where the platform has no ``flock``, runs start and resume unlocked, as before."""
    run_dir = tmp_path / "run"
    assert _train(run_dir, "--total-samples", "60") == 0
    inode = os.stat(run_dir)
    assert _train(run_dir, "--overwrite", "--total-samples", "60") == 0
    assert os.path.samestat(inode, os.stat(run_dir))
    monkeypatch.setattr(run_lock, "fcntl", None)
    assert not RunDirLock(run_dir).acquire() and not held_elsewhere(run_dir)
    other = tmp_path / "unlocked"
    assert _train(other, "--total-samples", "60") == 0
    assert _train(other, "--resume", "--total-samples", "120") == 0
    assert int(_record(other)[-1]["samples"]) >= 120


def test_a_lock_let_go_within_a_moment_is_taken(tmp_path):
    """A start that meets a lock held for an instant (another process only looking,
    ``held_elsewhere``) waits for it instead of refusing."""
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    holder = RunDirLock(run_dir)
    holder.acquire()
    threading.Timer(run_lock.RETRY_S, holder.release).start()
    lock = RunDirLock(run_dir)
    assert lock.acquire() and lock.held
    lock.release()


def test_a_killed_holder_leaves_no_stale_lock(tmp_path):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time; from maopg.experiment.run.lock import RunDirLock; "
            f"RunDirLock({str(run_dir)!r}).acquire(); print('held', flush=True); time.sleep(60)",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        assert held_elsewhere(run_dir)
    finally:
        holder.kill()
        holder.wait()
    assert not held_elsewhere(run_dir)


def test_grid_invocations_share_out_cells_and_jobs_give_the_same_curves(tmp_path):
    """Two cells train at once (``jobs=2``, their training spans overlap) while a third is held
    by another process: it is left to that process, and the results wait for it. Each curve is
    the one its cell gives alone, in this process."""
    runs_root, results = tmp_path / "runs", tmp_path / "results"
    lines: list[str] = []
    grid = dict(
        tasks=["tool_delivery"],
        methods=["async"],
        overrides=[*TINY, "total_samples=120"],
        log=lines.append,
    )
    cells = [Cell("tool_delivery", "async", seed) for seed in (0, 1, 2)]
    held = cells[0].run_dir(runs_root.resolve())
    held.mkdir(parents=True)
    with RunDirLock(held):
        assert run_grid(runs_root, seeds=[0], dry_run=True, **grid) == {cells[0]: BUSY}
        outcomes, written = reproduce(
            runs_root, results, seeds=[0, 1, 2], jobs=2, eval_episodes=0, **grid
        )
        assert outcomes == {cells[0]: BUSY, cells[1]: "done", cells[2]: "done"}
        assert written == [] and not results.exists()  # the holder redraws them when done
        assert not (held / CONFIG).exists()
    # both started before either ended: they trained at once
    started = [i for i, line in enumerate(lines) if "starting in" in line]
    ended = [i for i, line in enumerate(lines) if line.endswith(": done")]
    assert len(started) == len(ended) == 2 and max(started) < min(ended), lines
    alone = run_grid(tmp_path / "alone", seeds=[1, 2], in_process=True, **grid)
    assert set(alone.values()) == {"done"}
    for cell in cells[1:]:
        assert _record(cell.run_dir(runs_root.resolve())) == _record(
            cell.run_dir((tmp_path / "alone").resolve())
        )
    # once the cell is free, the next invocation trains it and draws the results
    outcomes, written = reproduce(
        runs_root, results, seeds=[0, 1, 2], jobs=2, eval_episodes=0, **grid
    )
    assert list(outcomes.values()) == ["done", "skipped", "skipped"]
    assert "tables.md" in {p.name for p in written}
    with pytest.raises(ValueError, match="drop --in-process"):
        run_grid(runs_root, jobs=2, in_process=True, **grid)
