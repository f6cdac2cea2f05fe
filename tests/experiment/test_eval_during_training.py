"""Evaluation during training (``eval_every``, issue #43): the evaluation curve published results
plot, logged beside the training return in ``metrics.csv``, TensorBoard and the readers, with
the training columns bit-identical whether the run evaluates or not, and kept across resumes."""

from __future__ import annotations

import csv
import itertools
import math
from pathlib import Path

import pytest
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main
from maopg.experiment.evaluation.evaluate import NO_EVALUATION, evaluation_due, evaluation_seeds
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import EVAL_COLUMNS, TIMING_COLUMNS, RunLog
from maopg.experiment.studies.runs import load_run
from maopg.experiment.training import trainer
from maopg.experiment.training.eta import RunRates, estimate_run
from maopg.learner import load_checkpoint

RUN = ["batch_ticks=60", "num_envs=2", "backend=threads", "env.max_ticks=30", "progress=false"]
RUN += ["video=false", "eval_episodes=0", "plot=false", "checkpoint_every=2", "--seed", "1"]
SECTION = {
    "async": ["ppo.epochs=2"],
    "partial": ["ppo.epochs=2"],
    "async-rnn": ["ppo.epochs=2"],
    "mac-dqn": ["dqn.learning_starts=40", "dqn.train_every=20"],
    "acac": ["acac.episodes_per_update=2"],
    "mac-iaicc": ["maciaicc.episodes_per_update=2"],
}
EVALUATE = ["eval_every=120", "eval_during_episodes=2"]


def _run(run_dir: Path, method: str, samples: int, *extra: str) -> list[dict[str, str]]:
    args = ["--method", method, *RUN, *SECTION[method], "--total-samples", str(samples)]
    assert main([*args, "--run-dir", str(run_dir), *extra]) == 0
    with (run_dir / "metrics.csv").open() as handle:
        return list(csv.DictReader(handle))


def _training(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    """The training columns that do not depend on the machine."""
    dropped = {*TIMING_COLUMNS, *EVAL_COLUMNS}
    return [{k: v for k, v in row.items() if k not in dropped} for row in rows]


def _evaluated(rows: list[dict[str, str]]) -> list[int]:
    return [int(r["samples"]) for r in rows if not math.isnan(float(r["eval_return"]))]


STATE_CRITICS = ["--task", "box_pushing_grid", "env.size=4", "maciaicc.critic=state"]
"""Mac-IAICC as the Box Pushing studies run it: critics of the grid's global state."""


@pytest.mark.parametrize(
    ("method", "sample", "task"),
    [
        ("async", "true", []),
        ("mac-dqn", "false", []),
        ("partial", "true", []),
        ("async-rnn", "true", []),
        ("acac", "true", []),
        ("mac-iaicc", "true", []),
        ("mac-iaicc", "true", STATE_CRITICS),
    ],
    ids=["async", "mac-dqn", "partial", "async-rnn", "acac", "mac-iaicc", "mac-iaicc-state"],
)
def test_the_training_columns_are_the_same_with_evaluation_on_or_off(
    tmp_path, method, sample, task
):
    """MAPPO sampled, Mac-DQN greedy (ε 0), and every other method the Box Pushing studies
    evaluate (`partial`, the recurrent policy, ACAC's and Mac-IAICC's rounds, whose ε the
    evaluation leaves out, and Mac-IAICC with state critics on the grid): the evaluation draws
    from no stream of the training, so the curve and the weights are the same bit for bit;
    without evaluation the file has no evaluation column."""
    off = _run(tmp_path / "off", method, 240, *task)
    on = _run(tmp_path / "on", method, 240, *task, *EVALUATE, f"eval_during_sample={sample}")
    assert not set(EVAL_COLUMNS) & set(off[0]) and list(on[0])[-4:] == list(EVAL_COLUMNS)
    assert _training(on) == _training(off)
    # one evaluation after each iteration that reached a multiple of 120 samples
    counts = [0] + [int(r["samples"]) for r in on]
    assert _evaluated(on) == [a for b, a in itertools.pairwise(counts) if a // 120 > b // 120]
    assert len(_evaluated(on)) == 2
    for row in on:
        if row["eval_return"] != "nan":
            length = float(row["eval_length"])  # Tool Delivery never ends within 30 ticks
            assert length == 30.0 if not task else 0 < length <= 30.0
            assert 0 <= float(row["eval_success"]) <= 1
    weights = [load_checkpoint(tmp_path / name / "final.pt") for name in ("off", "on")]
    for key in ("q",) if method == "mac-dqn" else ("policy", "critic"):
        for name, tensor in weights[0][key].items():
            assert weights[1][key][name].equal(tensor), (key, name)


def test_an_evaluation_logged_before_a_resume_is_kept_not_redone(tmp_path, monkeypatch):
    """A run resumed with evaluation switched on (resumable): its earlier rows read ``nan`` in
    the new columns, its later ones equal an uninterrupted run's; a second resume plays only
    the evaluations its rows do not hold yet."""
    whole = _run(tmp_path / "whole", "async", 480, *EVALUATE)
    evaluated = _evaluated(whole)  # at 129, 251, 375 and 497 samples
    assert len(evaluated) == 4
    played = []
    evaluate = trainer.evaluation.evaluate
    monkeypatch.setattr(
        trainer.evaluation,
        "evaluate",
        lambda *a, **k: played.append(k["seed"]) or evaluate(*a, **k),
    )
    run = tmp_path / "resumed"
    _run(run, "async", 120)
    rows = _run(run, "async", 360, *EVALUATE, "--resume")
    assert _evaluated(rows) == evaluated[1:3] and len(played) == 2
    rows = _run(run, "async", 480, *EVALUATE, "--resume")
    assert _evaluated(rows) == evaluated[1:] and len(played) == 3
    assert _training(rows) == _training(whole)
    assert [r["eval_return"] for r in rows[2:]] == [r["eval_return"] for r in whole[2:]]
    assert played[-1] == evaluation_seeds(1, 4)[0]  # the seeds of evaluation 4, as uninterrupted


def test_tensorboard_and_the_readers_show_the_evaluation(tmp_path, capsys):
    run = tmp_path / "run"
    rows = _run(run, "async", 240, *EVALUATE, "eval_during_episodes=1")
    events = EventAccumulator(str(run / "tb"), size_guidance={"scalars": 0})
    events.Reload()
    logged = {e.step: e.value for e in events.Scalars("eval/return")}
    assert logged == {int(r["samples"]): float(r["eval_return"]) for r in rows[1::2]}
    assert {"eval/return_std", "eval/success", "eval/length"} <= set(events.Tags()["scalars"])
    assert "train/eval_return" not in events.Tags()["scalars"]
    assert list(load_run(run).curve("eval_return")[0]) == [float(r["samples"]) for r in rows[1::2]]
    out = tmp_path / "plots"
    plot = ["plot", str(tmp_path), "--metric", "eval_return", "--out", str(out)]
    assert eval_main([*plot, "--reference-episodes", "0"]) == 0
    assert (out / "curves_tool_delivery.png").stat().st_size > 0


def test_the_wandb_mirror_gets_the_evaluation_beside_the_training(tmp_path):
    """W&B receives what TensorBoard does (``RunLog.scalars``); a row without an evaluation
    sends no evaluation value."""

    class Mirror:
        def __init__(self) -> None:
            self.logged: dict[int, dict[str, float]] = {}

        def log(self, step: int, values: dict[str, float]) -> None:
            self.logged.setdefault(step, {}).update(values)

    mirror = Mirror()
    columns = ("iteration", "samples", "episode_return", *EVAL_COLUMNS)
    log = RunLog(tmp_path, columns, mirror=mirror)  # type: ignore[arg-type]
    log.write({"iteration": 1, "samples": 60, "episode_return": 1.0, **NO_EVALUATION})
    evaluated = dict(zip(EVAL_COLUMNS, (2.0, 0.5, 1.0, 30.0), strict=True))
    log.write({"iteration": 2, "samples": 120, "episode_return": 3.0, **evaluated})
    log.close()
    assert mirror.logged == {
        60: {"train/episode_return": 1.0},
        120: {"train/episode_return": 3.0, "eval/return": 2.0, "eval/return_std": 0.5}
        | {"eval/success": 1.0, "eval/length": 30.0},
    }


def test_when_an_evaluation_is_due():
    assert [evaluation_due(b, a, 100) for b, a in [(0, 99), (99, 100), (150, 420), (0, 5)]] == [
        None,
        1,
        4,
        None,
    ]
    assert evaluation_due(0, 10**6, 0) is None
    assert evaluation_seeds(3, 1) != evaluation_seeds(3, 2) != evaluation_seeds(4, 2)


def test_the_eta_counts_the_evaluations_still_due():
    config = TrainConfig(total_samples=1000, backend="local", num_envs=1, eval_episodes=0)
    rates = RunRates(samples_per_s=100.0, collecting_s=1.0, ticks=100, episode_length=20.0)
    plain, _ = estimate_run(config, 400, rates, max_ticks=150)
    config.eval_every, config.eval_during_episodes = 250, 3
    # 500, 750 and 1000 are due: 3 episodes of 20 ticks at 0.01 s each, until one was timed
    estimated, _ = estimate_run(config, 400, rates, max_ticks=150)
    assert estimated == pytest.approx(plain + 3 * 3 * 20 * 0.01)
    timed = RunRates(**{**rates.__dict__, "evaluation_s": 2.0})
    assert estimate_run(config, 400, timed, max_ticks=150)[0] == pytest.approx(plain + 6.0)


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ("eval_every=-1", r"eval_every must be >= 0, got -1"),
        ("eval_during_episodes=0", r"eval_during_episodes must be >= 1, got 0"),
        ("eval_during_sample=maybe", r"eval_during_sample expected bool, got 'maybe'"),
    ],
)
def test_a_bad_evaluation_setting_is_one_line(tmp_path, user_error, setting, message):
    run = tmp_path / "run"
    user_error(main, [*RUN, "--run-dir", str(run), setting], message)
    assert not run.exists()
