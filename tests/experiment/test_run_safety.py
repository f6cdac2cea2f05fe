"""Data loss and hangs of the ``train`` and ``eval`` command lines (issues #17 and #46), each met
where a user meets it: TensorBoard after a resume, ``--resume`` of the wrong directory or
checkpoint, a failed start, a video of an endless episode, a diverging run, a corrupt or edited
checkpoint, a kill during a checkpoint write, a full disk, a resume with a smaller budget."""

from __future__ import annotations

import csv
import errno
import os
import re
import shutil
import zipfile
from pathlib import Path

import imageio.v2 as imageio
import pytest
import torch
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from maopg.env import make_env, video
from maopg.env.rollout import RandomPolicy
from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main
from maopg.experiment.evaluation import evaluate as evaluation
from maopg.experiment.run.directory import TIMING_COLUMNS, RunLog
from maopg.learner import load_checkpoint, save_checkpoint
from maopg.learner.checkpoint import CHECKSUM_KEY

RUN = [
    "--seed",
    "1",
    "batch_ticks=60",
    "num_envs=2",
    "progress=false",
    "video=false",
    "eval_episodes=0",
]
PPO = [*RUN, "ppo.epochs=2", "checkpoint_every=2"]
DQN = ["--method", "mac-dqn", *RUN, "dqn.learning_starts=40", "dqn.train_every=20"]


def _train(run_dir: Path, *args: str) -> None:
    assert main([*PPO, "--run-dir", str(run_dir), *args]) == 0


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A finished 240-sample run (checkpoints every 2 iterations), copied by the tests."""
    run_dir = tmp_path_factory.mktemp("finished") / "run"
    _train(run_dir, "--total-samples", "240")
    return run_dir


def _copy(run_dir: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    return copy


def _rows(run_dir: Path) -> list[dict[str, str]]:
    """``metrics.csv`` without the columns that depend on the machine."""
    with (run_dir / "metrics.csv").open() as handle:
        return [
            {k: v for k, v in row.items() if k not in TIMING_COLUMNS}
            for row in csv.DictReader(handle)
        ]


def _scalars(run_dir: Path) -> dict[str, list[tuple[int, float]]]:
    """Every TensorBoard scalar as TensorBoard shows it (purged events hidden)."""
    events = EventAccumulator(str(run_dir / "tb"), size_guidance={"scalars": 0})
    events.Reload()
    return {
        tag: [(e.step, e.value) for e in events.Scalars(tag)] for tag in events.Tags()["scalars"]
    }


def test_a_resumed_run_keeps_every_tensorboard_scalar(tmp_path):
    """A run killed after a checkpoint (here: its later rows written, then the checkpoint set
    back) and resumed shows in TensorBoard exactly the scalars of the uninterrupted run."""
    whole, killed, early = tmp_path / "whole", tmp_path / "killed", tmp_path / "early"
    _train(whole, "--total-samples", "480")
    _train(killed, "--total-samples", "300")  # rows past the checkpoint the kill falls back to
    _train(early, "--total-samples", "120")  # the same run's checkpoint at 120+ samples
    shutil.copy(early / "checkpoint.pt", killed / "checkpoint.pt")
    for name in ("done.json", "final.pt"):
        (killed / name).unlink()
    assert main(["--resume", "--run-dir", str(killed), "--total-samples", "480"]) == 0

    expected, resumed = _scalars(whole), _scalars(killed)
    assert sorted(resumed) == sorted(expected) and len(expected["train/episodes"]) >= 8
    for tag, points in expected.items():
        if tag.removeprefix("train/") in TIMING_COLUMNS:
            assert [s for s, _ in resumed[tag]] == [s for s, _ in points], tag
        else:
            assert resumed[tag] == points, tag


def test_resume_of_no_run_fails_and_a_run_without_checkpoint_restarts(
    tmp_path, finished, user_error, capsys
):
    empty = tmp_path / "empty"
    empty.mkdir()
    for where in (empty, tmp_path / "mistyped"):
        user_error(main, ["--resume", "--run-dir", str(where)], rf"{where} holds no run")
    assert list(empty.iterdir()) == [] and not (tmp_path / "mistyped").exists()

    # killed before its first checkpoint: config.json, a row and some events, no checkpoint
    run_dir = _copy(finished, tmp_path)
    for name in ("checkpoint.pt", "final.pt", "done.json"):
        (run_dir / name).unlink()
    assert main(["--resume", "--run-dir", str(run_dir)]) == 0
    assert "has no checkpoint.pt yet; --resume starts it from the beginning" in (
        capsys.readouterr().err
    )
    assert _rows(run_dir) == _rows(finished)
    assert _scalars(run_dir)["train/episodes"] == _scalars(finished)["train/episodes"]


def test_resume_checks_the_checkpoint_against_the_run(tmp_path, finished, user_error):
    run_dir = _copy(finished, tmp_path)
    (run_dir / "done.json").unlink()
    resume = ["--resume", "--run-dir", str(run_dir), "--total-samples", "360"]
    checkpoint = run_dir / "checkpoint.pt"
    user_error(
        main,
        [*resume, "--method", "mac-dqn"],
        r"the config differs from the saved one in method \(saved 'async', given 'mac-dqn'\)",
    )
    other = tmp_path / "other"
    _train(other, "--total-samples", "60", "hidden=32")
    shutil.copy(other / "checkpoint.pt", checkpoint)
    user_error(
        main,
        resume,
        rf"checkpoint {checkpoint} was written by another run: .*hidden "
        r"\(checkpoint 32, config.json 128\)",
    )
    # its config made to agree, the weights still do not fit: named, no torch traceback
    state = load_checkpoint(checkpoint)
    state["config"] = load_checkpoint(finished / "checkpoint.pt")["config"]
    save_checkpoint(checkpoint, state)
    err = user_error(
        main, resume, rf"checkpoint {checkpoint} does not fit .*another architecture.*size mismatch"
    )
    assert len(err.strip().splitlines()) == 1

    # a finished run without its checkpoint (a results folder) cannot be extended
    shutil.rmtree(run_dir)
    run_dir = _copy(finished, tmp_path)
    (run_dir / "checkpoint.pt").unlink()
    user_error(main, resume, "cannot extend .* it finished at 2[0-9]+ and has no checkpoint.pt")
    assert (run_dir / "done.json").exists() and (run_dir / "final.pt").exists()


@pytest.mark.parametrize(
    ("typo", "named"),
    [
        ("env.max_tikcs=5", "max_tikcs"),
        ("env.max_ticks=many", r"env\.max_ticks expected int"),
        ("layers=0", "layers must be >= 1"),
        ("ppo.lr=-1", r"ppo\.lr must be > 0"),
    ],
)
def test_a_failed_start_leaves_nothing_behind(tmp_path, user_error, typo, named):
    run_dir = tmp_path / "run"
    args = [*PPO, "--total-samples", "60", "--run-dir", str(run_dir)]
    err = user_error(main, [*args, typo], named)
    assert len(err.strip().splitlines()) == 1 and not run_dir.exists()
    assert main(args) == 0


def test_the_video_of_an_endless_episode_is_cut(tmp_path, monkeypatch, capsys):
    """``env.max_ticks=1000000000``: the final video stops at its tick limit (set low here; by
    default :data:`maopg.env.video.VIDEO_MAX_TICKS`), and says so."""
    monkeypatch.setattr(video, "VIDEO_MAX_TICKS", 30)
    run_dir = tmp_path / "run"
    _train(run_dir, "--total-samples", "60", "video=true", "env.max_ticks=1000000000")
    assert "rollout.mp4 stops at tick 30; the episode went on" in capsys.readouterr().err
    reader = imageio.get_reader(run_dir / "rollout.mp4")
    try:
        assert reader.count_frames() == 1 + 4 * 30
    finally:
        reader.close()
    assert (run_dir / "done.json").exists()


def test_the_evaluation_of_an_endless_episode_is_cut(tmp_path, monkeypatch, capsys):
    """``env.max_ticks=1000000000``: each episode of the evaluation after training stops at its
    tick limit (set low here; by default
    :data:`maopg.experiment.evaluation.evaluate.EVAL_MAX_TICKS`), a note says so, and TensorBoard
    has the returns."""
    monkeypatch.setattr(evaluation, "EVAL_MAX_TICKS", 30)
    run_dir = tmp_path / "run"
    _train(run_dir, "--total-samples", "60", "eval_episodes=2", "env.max_ticks=1000000000")
    assert (
        "note: evaluation: 4 of the 4 episodes (greedy and sampled) went on past tick 30 and "
        "were cut there; their returns are over the first 30 ticks"
    ) in capsys.readouterr().err
    assert {"eval/return_greedy", "eval/return_sampled"} <= set(_scalars(run_dir))
    assert (run_dir / "done.json").exists()


def test_a_cut_episode_keeps_the_return_of_its_first_ticks():
    """A bound above the episode changes nothing; one inside it stops the episode at that tick
    with the return of the ticks played, however an option is under way."""
    env = make_env("tool_delivery", seed=0)
    try:
        full = evaluation.evaluate(env, RandomPolicy(env.spec, 0), 1, seed=3)
        loose = evaluation.evaluate(env, RandomPolicy(env.spec, 0), 1, seed=3, max_ticks=10**6)
        assert (loose.returns, loose.lengths, loose.cut) == (full.returns, full.lengths, [False])
        rewards: list[float] = []
        env.add_tick_listener(lambda _env, reward: rewards.append(reward))
        cut = evaluation.evaluate(env, RandomPolicy(env.spec, 0), 1, seed=3, max_ticks=17)
    finally:
        env.close()
    assert full.lengths[0] > 17 and cut.cut == [True] and cut.lengths == [17]
    assert cut.returns == [pytest.approx(sum(rewards))] and not cut.solved[0]


def test_non_finite_settings_are_refused_before_anything_is_written(tmp_path, user_error):
    for setting, method in (("ppo.ent_coef=nan", PPO), ("dqn.lr=inf", DQN)):
        run_dir = tmp_path / setting
        args = [*method, "--total-samples", "60", "--run-dir", str(run_dir), setting]
        user_error(main, args, rf"{setting.split('=')[0]} must be a finite number")
        assert not run_dir.exists()


@pytest.mark.parametrize(
    ("args", "message", "kept"),
    [
        ([*PPO, "ppo.lr=1e30"], "iteration 1 .*the actor's loss became nan; no checkpoint.pt", 0),
        (
            [*DQN, "checkpoint_every=1", "dqn.lr=1e30", "dqn.learning_starts=130"],
            "iteration 3 .*the TD loss became (nan|inf); checkpoint.pt keeps iteration 2",
            2,
        ),
    ],
)
def test_training_that_diverges_stops_at_the_first_nan(tmp_path, user_error, args, message, kept):
    """A finite but huge step size: the run stops with one line, its last checkpoint (if any)
    is the last finite state, and nothing claims to be its result."""
    run_dir = tmp_path / "run"
    args = [*args, "--total-samples", "600", "--run-dir", str(run_dir), "env.max_ticks=40"]
    user_error(main, args, message)
    assert not (run_dir / "final.pt").exists() and not (run_dir / "done.json").exists()
    assert (run_dir / "checkpoint.pt").exists() == bool(kept)
    if kept:
        state = load_checkpoint(run_dir / "checkpoint.pt")
        assert state["iteration"] == kept
        assert all(torch.isfinite(w).all() for w in state["q"].values())  # Mac-DQN's weights


def test_flipped_bytes_in_a_checkpoint_are_an_error_of_eval(tmp_path, finished, user_error):
    final = tmp_path / "final.pt"
    shutil.copy(finished / "final.pt", final)
    with zipfile.ZipFile(final) as archive:  # the largest tensor's data record
        record = max(archive.infolist(), key=lambda info: info.file_size)
        assert "/data/" in record.filename and record.compress_type == zipfile.ZIP_STORED
    data = bytearray(final.read_bytes())
    header = data[record.header_offset : record.header_offset + 30]  # the record's local header
    name_length, extra_length = (int.from_bytes(header[i : i + 2], "little") for i in (26, 28))
    start = record.header_offset + 30 + name_length + extra_length  # its data follows
    middle = start + record.file_size // 2
    data[middle : middle + 4] = bytes(b ^ 0xFF for b in data[middle : middle + 4])
    final.write_bytes(bytes(data))
    evaluate = ["evaluate", "--checkpoint", str(final), "--episodes", "1"]
    user_error(eval_main, evaluate, rf"checkpoint {final} is corrupt or was edited: its entries")


@pytest.mark.parametrize("edit", ["relabelled", "unchecked"])
def test_an_edited_checkpoint_neither_evaluates_nor_resumes(tmp_path, finished, user_error, edit):
    """Async weights whose stored config was edited to say ``sync-cut``, or whose checksum was
    deleted: the checksum covers the config too, and a checkpoint of today's format without it
    is refused. One line naming the file, from ``eval`` and from ``--resume``."""
    run_dir = _copy(finished, tmp_path)
    (run_dir / "done.json").unlink()
    for name in ("final.pt", "checkpoint.pt"):
        state = torch.load(run_dir / name, weights_only=True)
        if edit == "relabelled":
            state["config"]["method"] = "sync-cut"
        else:
            del state[CHECKSUM_KEY]
        torch.save(state, run_dir / name)
    if edit == "relabelled":
        why = "is corrupt or was edited: its entries do not match"
    else:
        why = rf"lacks the checksum its format carries \('{CHECKSUM_KEY}'; it has none\)"
    final, checkpoint = (re.escape(str(run_dir / name)) for name in ("final.pt", "checkpoint.pt"))
    evaluate = ["evaluate", "--checkpoint", str(run_dir / "final.pt"), "--episodes", "1"]
    user_error(eval_main, evaluate, rf"checkpoint {final} {why}")
    resume = ["--resume", "--run-dir", str(run_dir), "--total-samples", "360"]
    user_error(main, resume, rf"checkpoint {checkpoint} {why}")


@pytest.mark.parametrize(
    ("cause", "where"),
    [(errno.ENOSPC, "checkpoint write"), (errno.EROFS, "checkpoint move"), (errno.ENOSPC, "row")],
)
def test_a_full_disk_or_read_only_file_system_is_one_line(
    tmp_path, finished, user_error, monkeypatch, cause, where
):
    """The machine refuses a write of a resumed run (simulated: the disk fills in the middle
    of the checkpoint's write, the file system turns read-only when it is moved over the
    previous one, the disk fills as a row is appended): one line naming the file (the run
    directory, for a write into a file already open) and the cause, status 2, the previous
    checkpoint intact and verified, no temporary left; the run goes on from it once the disk
    takes writes again."""
    run_dir = _copy(finished, tmp_path)
    (run_dir / "done.json").unlink()
    checkpoint = run_dir / "checkpoint.pt"
    kept = load_checkpoint(checkpoint)["iteration"]
    strerror = os.strerror(cause)
    if where == "checkpoint write":

        def fill_up(state, handle) -> None:
            handle.write(b"PK\x03\x04" + bytes(4096))  # half a checkpoint, then no space
            raise OSError(cause, strerror)

        monkeypatch.setattr(torch, "save", fill_up)
    elif where == "checkpoint move":
        move = os.replace

        def read_only(src, dst) -> None:
            if Path(dst).name == "checkpoint.pt":
                raise OSError(cause, strerror, str(src), None, str(dst))
            move(src, dst)

        monkeypatch.setattr(os, "replace", read_only)
    else:

        def no_space(self, row) -> None:
            raise OSError(cause, strerror)

        monkeypatch.setattr(RunLog, "write", no_space)
    named = checkpoint if where.startswith("checkpoint") else run_dir
    intact = r" \(the checkpoint.pt there before is intact\)" if named == checkpoint else ""
    resume = ["--resume", "--run-dir", str(run_dir), "--total-samples", "360", "plot=false"]
    err = user_error(
        main, resume, rf"error: cannot write {re.escape(str(named))}: {strerror}{intact}$"
    )
    # One error line; the run's own notes (its budget's rounding) may come before it.
    assert len([line for line in err.splitlines() if line and not line.startswith("note: ")]) == 1
    assert load_checkpoint(checkpoint)["iteration"] == kept
    assert not list(run_dir.glob(".checkpoint.pt.*.tmp"))
    if where == "row":  # the same for all: the run goes on from the checkpoint kept
        monkeypatch.undo()
        assert main(resume) == 0 and (run_dir / "done.json").exists()


def test_a_resume_removes_the_temporary_of_a_killed_checkpoint_write(tmp_path, finished):
    run_dir = _copy(finished, tmp_path)
    (run_dir / "done.json").unlink()
    orphans = [run_dir / ".checkpoint.pt.k9_x2abq.tmp", run_dir / ".final.pt.0a1b2c3d.tmp"]
    others = [run_dir / ".checkpoint.pt.tmp", run_dir / "notes.tmp", run_dir / ".x.pt.abcdefgh.tmp"]
    for path in (*orphans, *others):
        path.write_bytes(b"half a checkpoint")
    assert main(["--resume", "--run-dir", str(run_dir), "--total-samples", "300"]) == 0
    assert not any(path.exists() for path in orphans)
    assert all(path.exists() for path in others)  # not our temporaries: kept


def test_a_resume_below_the_trained_samples_says_so(tmp_path, finished, capsys):
    run_dir = _copy(finished, tmp_path)
    trained = int((run_dir / "metrics.csv").read_text().splitlines()[-1].split(",")[1])
    assert main(["--resume", "--run-dir", str(run_dir), "--total-samples", "100"]) == 0
    assert f"already trained {trained} samples, more than the budget of 100" in (
        capsys.readouterr().err
    )
    # unfinished (killed after its last checkpoint): it finishes at the checkpoint
    for name in ("done.json", "final.pt"):
        (run_dir / name).unlink()
    assert main(["--resume", "--run-dir", str(run_dir), "--total-samples", "100"]) == 0
    err = capsys.readouterr().err
    assert f"already trained {trained} samples, more than the budget of 100" in err
    assert (run_dir / "done.json").exists() and (run_dir / "final.pt").exists()
    for name in ("done.json", "final.pt"):  # a budget of exactly the trained samples
        (run_dir / name).unlink()
    assert main(["--resume", "--run-dir", str(run_dir), "--total-samples", str(trained)]) == 0
    err = capsys.readouterr().err
    assert f"already trained {trained} samples, which reaches the budget of {trained} " in err
