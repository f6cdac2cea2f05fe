"""Evaluation tools: tables and plots on fabricated and real run directories, checkpoint
evaluation and videos, and the resumable reproduction grid."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest

from maopg.env import make_env, video
from maopg.env.rollout import reference_policy, run_episode
from maopg.env.video import video_title
from maopg.experiment.cli.eval_cli import main
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.evaluation import timeline
from maopg.experiment.evaluation.evaluate import evaluate, option_shares
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import RUN_SECTIONS, TrainConfig
from maopg.experiment.run.directory import DONE, FINAL
from maopg.experiment.studies import (
    Study,
    StudyTask,
    frozen,
    get_study,
    register_study,
    registry,
    study_names,
)
from maopg.experiment.studies.cache import behaviour
from maopg.experiment.studies.grid import Cell, cell_config, cell_state, run_grid
from maopg.experiment.studies.plots import curve_table, plot_all, plot_task
from maopg.experiment.studies.results import reference_lines, reproduce, write_results
from maopg.experiment.studies.runs import (
    NOT_LEARNT_SECTIONS,
    discover_runs,
    final,
    group_runs,
    load_run,
    mean_curve,
    peak,
    samples_to_threshold,
    trailing_mean,
)
from maopg.experiment.studies.tables import peak_table, threshold_table
from maopg.experiment.training.trainer import RESUMABLE_KEYS
from maopg.policy import DistributionActor, QActor

RUN = [
    "batch_ticks=60",
    "num_envs=2",
    "checkpoint_every=1",
    "env.max_ticks=40",
    "video=false",
    "eval_episodes=0",
    "plot=false",
]
TINY = [*RUN, "ppo.epochs=2"]
TINY_DQN = [*RUN, "dqn.learning_starts=60", "dqn.train_every=20"]
NAN = math.nan


def _fake_run(
    root: Path,
    task: str,
    method: str,
    seed: int,
    samples,
    returns,
    paper=None,
    finished=True,
    config=None,
):
    """A run directory as the trainer writes it, with known numbers."""
    run_dir = root / task / method / f"seed{seed}"
    run_dir.mkdir(parents=True)
    settings = {"task": task, "method": method, "seed": seed, **(config or {})}
    (run_dir / "config.json").write_text(json.dumps(settings))
    paper = paper if paper is not None else [r / 10 if not math.isnan(r) else -1 for r in returns]
    with (run_dir / "metrics.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["iteration", "samples", "episode_return", "option_step_reward"])
        for k, (s, r, p) in enumerate(zip(samples, returns, paper, strict=True), 1):
            writer.writerow([k, s, "nan" if math.isnan(r) else repr(r), repr(p)])
    if finished:
        (run_dir / DONE).write_text("{}")
    return run_dir


@pytest.fixture
def fabricated(tmp_path):
    root = tmp_path / "runs"
    # async: seed 0 peaks at 220 (reaches 200 at 300 samples), seed 1 peaks at 180 (never).
    _fake_run(root, "tool_delivery", "async", 0, [100, 200, 300, 400], [NAN, 50.0, 210.0, 220.0])
    _fake_run(root, "tool_delivery", "async", 1, [100, 200, 300, 400], [-20.0, 80.0, 180.0, 150.0])
    # sync-cut: both seeds reach 200 (at 400 and 200 samples).
    _fake_run(root, "tool_delivery", "sync-cut", 0, [100, 200, 300, 400], [0.0, 10.0, 90.0, 205.0])
    _fake_run(root, "tool_delivery", "sync-cut", 1, [100, 200, 300, 400], [0.0, 250.0, 240.0, 0.0])
    return root


def test_trailing_mean_and_curve_statistics(fabricated):
    assert np.allclose(trailing_mean(np.array([1.0, 3.0, 5.0, 7.0]), 2), [1.0, 2.0, 4.0, 6.0])
    runs = discover_runs([fabricated])
    assert [(r.method, r.seed) for r in runs] == [
        ("async", 0),
        ("async", 1),
        ("sync-cut", 0),
        ("sync-cut", 1),
    ]
    a0, a1 = runs[0], runs[1]
    samples, values = a0.curve()
    assert samples.tolist() == [200, 300, 400] and values.tolist() == [50, 210, 220]
    assert peak(a0) == 220 and peak(a0, window=2) == 215
    assert samples_to_threshold(a0, 200) == 300 and math.isnan(samples_to_threshold(a1, 200))
    grid, mean, std = mean_curve([a0, a1], points=3)
    # the range both seeds cover, 200..400 (seed 0 has no return at 100); at 300 (210 + 180) / 2
    assert grid.tolist() == [200, 300, 400]
    assert mean.tolist() == [65.0, 195.0, 185.0] and std.tolist() == [15.0, 15.0, 35.0]
    # seeds whose reported ranges do not meet still draw a line: each point the seeds covering it
    early = _fake_run(fabricated, "water_filling", "async", 0, [100, 200], [1.0, 3.0])
    late = _fake_run(fabricated, "water_filling", "async", 1, [300, 400], [5.0, 7.0])
    grid, mean, std = mean_curve(discover_runs([early, late]), points=7)
    assert grid.tolist() == [100, 150, 200, 300, 350, 400]  # 250 lies between the two: left out
    assert mean.tolist() == [1.0, 2.0, 3.0, 5.0, 6.0, 7.0] and not std.any()


def test_runs_that_learnt_from_different_settings_are_not_pooled(tmp_path):
    """A run at env.max_ticks=100 or with a recurrent Q is its own row and line, labelled with
    what differs; where, how and how fast a run ran (backend, workers, device) does not split."""
    root = tmp_path / "runs"
    base = {"num_envs": 4, "env_overrides": {}, "dqn": {"recurrent": False}, "backend": "local"}
    for seed, (backend, ticks) in enumerate([("local", None), ("ray", None), ("local", 100)]):
        env = {"max_ticks": ticks} if ticks else {}
        config = {**base, "backend": backend, "env_overrides": env}
        _fake_run(root, "tool_delivery", "mac-dqn", seed, [100], [1.0], config=config)
    config = {**base, "dqn": {"recurrent": True}}
    _fake_run(root, "tool_delivery", "mac-dqn", 3, [100], [2.0], config=config)
    old = {"num_envs": 4}  # written before the dqn section existed: compared on what it has
    _fake_run(root, "tool_delivery", "async", 0, [100], [3.0], config=old)
    _fake_run(root, "tool_delivery", "async", 1, [100], [3.0], config={**old, "ppo": {"lr": 1}})
    groups = group_runs(discover_runs([root]))
    assert {label: [r.seed for r in runs] for (_, label), runs in groups.items()} == {
        "async": [0, 1],
        "mac-dqn [dqn.recurrent=False, env.max_ticks=100]": [2],
        "mac-dqn [dqn.recurrent=False, env.max_ticks=default]": [0, 1],
        "mac-dqn [dqn.recurrent=True, env.max_ticks=default]": [3],
    }
    table = peak_table(discover_runs([root]))
    assert "| tool_delivery | mac-dqn [dqn.recurrent=True, env.max_ticks=default] | 1 |" in table
    plot_task(discover_runs([root]), tmp_path / "plot", references={"scripted": 2.5})
    svg = (tmp_path / "plot.svg").read_text()
    assert "mac-dqn [dqn.recurrent=True, env.max_ticks=default] (1 seed)" in svg
    assert "scripted (2)" in svg  # the reference level, as a dashed line


def test_a_setting_newer_than_a_runs_config_reads_as_its_default(tmp_path):
    """A config.json written before ``ppo.ent_decay`` existed trained with its default (0): a
    run that sets it is a row of its own, not pooled with the older runs; one that sets the
    default is pooled with them."""
    root = tmp_path / "runs"
    old = {"ppo": {"lr": 0.0005}}  # no ent_decay: the config of an older version
    _fake_run(root, "tool_delivery", "async", 0, [100], [1.0], config=old)
    _fake_run(root, "tool_delivery", "async", 1, [100], [1.0], config={"ppo": {"ent_decay": 0}})
    _fake_run(root, "tool_delivery", "async", 2, [100], [1.0], config={"ppo": {"ent_decay": 9}})
    groups = group_runs(discover_runs([root]))
    assert {label: [r.seed for r in runs] for (_, label), runs in groups.items()} == {
        "async [ppo.ent_decay=0]": [0, 1],
        "async [ppo.ent_decay=9]": [2],
    }


def test_a_paper_tables_analog_is_written_where_its_methods_were_run(tmp_path):
    """Table I (async vs Mac-DQN) and Table II (async vs partial) analogs appear in tables.md
    only where the runs hold both of their methods, never as empty sections."""
    root = tmp_path / "runs"
    for method in ("async", "mac-dqn"):
        _fake_run(root, "tool_delivery", method, 0, [100, 200], [1.0, 2.0])
    _fake_run(root, "water_filling", "async", 0, [100, 200], [1.0, 2.0])  # no Mac-DQN there
    write_results(discover_runs([root]), tmp_path / "results", thresholds={})
    tables = (tmp_path / "results" / "tables.md").read_text()
    assert "Table I analog" in tables and "Table II analog" not in tables
    table_one = tables.split("## Table I analog")[1]
    assert "| tool_delivery | async | 1 |" in table_one
    assert "| tool_delivery | mac-dqn | 1 |" in table_one
    assert "water_filling" not in table_one


def test_settings_that_differ_between_methods_are_stated(tmp_path, capsys):
    """An async and a sync-cut run that learnt from different settings are no like-for-like
    comparison: the table and the plot say what differs; where and how they ran (backend,
    workers, device, logger, W&B) and another method's section (saved by older versions) do
    not count."""
    root = tmp_path / "runs"
    ppo, dqn = {"lr": 0.1}, {"buffer_size": 5}
    base = {"hidden": 128, "env_overrides": {}, "ppo": ppo, "dqn": dqn, "backend": "local"}
    base |= {"num_workers": 0, "device": "cpu", "logger": "tensorboard", "wandb": {"project": "a"}}
    cut = {**base, "hidden": 32, "env_overrides": {"max_ticks": 100}, "dqn": {"buffer_size": 7}}
    cut |= {"backend": "ray", "num_workers": 4, "device": "cuda", "logger": "wandb"}
    cut |= {"wandb": {"project": "b"}, "ray": {"address": "auto"}, "eval_episodes": 0}
    for seed in (0, 1):
        _fake_run(root, "tool_delivery", "async", seed, [100, 200], [1.0, 2.0], config=base)
        _fake_run(root, "tool_delivery", "sync-cut", seed, [100, 200], [0.0, 1.0], config=cut)
    _fake_run(root, "water_filling", "async", 0, [100], [1.0], config=base)
    _fake_run(root, "water_filling", "sync-cut", 0, [100], [1.0], config={**base, "seed": 3})
    runs = discover_runs([root])
    assert set(NOT_LEARNT_SECTIONS) == {f"{name}." for name in RUN_SECTIONS}
    note = (
        "Settings that differ between the tool_delivery rows: env.max_ticks (async default, "
        "sync-cut 100); hidden (async 128, sync-cut 32).\n"
    )
    table = peak_table(runs)
    assert table.endswith("|\n\n" + note)  # one line under the table; none for water_filling
    assert "| tool_delivery | async | 2 |" in table and "| tool_delivery | sync-cut | 2 |" in table
    assert "water_filling rows" not in table
    assert note not in peak_table(runs, methods=["async"])  # one group: nothing to compare
    assert main(["table", str(root)]) == 0
    assert note in capsys.readouterr().out
    plot_task([r for r in runs if r.task == "tool_delivery"], tmp_path / "plot")
    svg = (tmp_path / "plot.svg").read_text()
    assert "Settings that differ: env.max_ticks (async default, sync-cut 100); hidden" in svg
    plot_task([r for r in runs if r.task == "water_filling"], tmp_path / "shared")
    assert "Settings that differ" not in (tmp_path / "shared.svg").read_text()


def test_plot_draws_the_reference_policies_at_the_runs_task_settings(tmp_path, capsys):
    """The scripted and random levels are measured at the runs' task settings (here a short
    Tool Delivery); runs that differ in them get no lines and a note saying why."""
    settings = {"max_ticks": 20}
    root = tmp_path / "runs"
    for method in ("async", "sync-cut"):
        config = {"env_overrides": settings}
        _fake_run(root, "tool_delivery", method, 0, [100, 200], [1.0, 2.0], config=config)
    runs = discover_runs([root])
    lines, notes = reference_lines(runs, 2)
    assert notes == [] and list(lines) == ["tool_delivery"]
    env = make_env("tool_delivery", seed=0, overrides=settings)
    try:
        for name in ("scripted", "random"):
            alone = evaluate(env, reference_policy(name, env), 2)
            assert all(n <= 20 for n in alone.lengths)
            assert lines["tool_delivery"][name] == alone.summary["return_mean"]
    finally:
        env.close()
    out = tmp_path / "fig"
    plot = ["plot", str(root), "--out", str(out), "--reference-episodes", "2"]
    assert main([*plot, "--no-progress"]) == 0
    printed = capsys.readouterr()
    assert printed.err == ""
    svg = (out / "curves_tool_delivery.svg").read_text()
    for name, level in lines["tool_delivery"].items():
        assert f"{name} ({level:,.0f})" in svg
    _fake_run(root, "tool_delivery", "async", 1, [100, 200], [1.0, 2.0])  # at the defaults
    assert main(plot) == 0
    printed = capsys.readouterr()
    assert "tool_delivery: no reference lines, its runs differ in env.max_ticks" in printed.out
    assert "evaluating" not in printed.err
    assert "scripted (" not in (out / "curves_tool_delivery.svg").read_text()


def test_tables_on_fabricated_runs(fabricated):
    runs = discover_runs([fabricated])
    table = peak_table(runs, window=1)
    lines = table.splitlines()
    # final = the last 10% of samples (> 360: the iteration at 400): async 220 and 150
    assert lines[2] == (
        "| tool_delivery | async | 2 | 200.0 ± 20.0 | 185.0 ± 35.0 | 20.00 ± 2.00 | 400 ± 0 |"
    )
    assert lines[3] == (
        "| tool_delivery | sync-cut | 2 | 227.5 ± 22.5 | 102.5 ± 102.5 | 22.75 ± 2.25 | 400 ± 0 |"
    )
    thresholds = threshold_table(runs, {"tool_delivery": 200}, window=1).splitlines()
    assert thresholds[2] == "| tool_delivery | async | 200 | 300 | 1/2 |"
    assert thresholds[3] == "| tool_delivery | sync-cut | 200 | 300 ± 100 | 2/2 |"
    # smoothing over 2 iterations: async seed 0 peaks at (210 + 220) / 2
    smoothed = peak_table(runs, window=2, methods=["sync-cut", "async"]).splitlines()
    assert smoothed[2].startswith("| tool_delivery | sync-cut |")
    assert "| 190.0 ± 25.0 |" in smoothed[3]
    unknown = threshold_table(
        [r for r in runs if r.method == "async"], {"tool_delivery": 1e9}, window=1
    )
    assert "| — | 0/2 |" in unknown


def test_unfinished_runs_stay_out_of_statistics_unless_asked_for(fabricated):
    """A seed in progress would shorten its method's common curve range and lower its peak;
    a run killed before its first iteration has a header-only metrics.csv."""
    _fake_run(fabricated, "tool_delivery", "async", 2, [100], [-50.0], finished=False)
    starting = _fake_run(fabricated, "tool_delivery", "async", 3, [], [], finished=False)
    assert load_run(starting).samples.size == 0 and math.isnan(final(load_run(starting)))
    assert [r.seed for r in discover_runs([fabricated]) if r.method == "async"] == [0, 1]
    every = discover_runs([fabricated], unfinished=True)
    assert [r.seed for r in every if r.method == "async"] == [0, 1, 2, 3]
    table = peak_table(every, methods=["async"]).splitlines()
    # seed 3 reported nothing yet: it counts as a seed but adds no value (peaks 220, 180, -50)
    assert table[2].startswith("| tool_delivery | async | 4 (2 unfinished) | 116.7 ± 119.0 |")
    one = peak_table([r for r in every if r.seed == 2]).splitlines()
    assert one[2] == "| tool_delivery | async | 1 (1 unfinished) | -50.0 | -50.0 | -5.00 | 100 |"
    assert "| 20.00 ± 2.00 |" in peak_table(discover_runs([fabricated]), methods=["async"])


def test_table_and_plot_commands(fabricated, tmp_path, capsys):
    out_md = tmp_path / "t.md"
    assert main(["table", str(fabricated), "--window", "1", "--out", str(out_md)]) == 0
    printed = capsys.readouterr().out
    assert "| tool_delivery | async | 200 | 300 | 1/2 |" in printed
    assert out_md.read_text() in printed
    plot = ["plot", str(fabricated), "--out", str(tmp_path / "fig"), "--window", "1"]
    assert main([*plot, "--reference-episodes", "0"]) == 0
    assert "evaluating" not in capsys.readouterr().err  # no reference lines, no evaluation
    png, svg = (
        tmp_path / "fig" / "curves_tool_delivery.png",
        tmp_path / "fig/curves_tool_delivery.svg",
    )
    image = imageio.imread(png)
    assert image.ndim == 3 and image.shape[0] > 300 and image.shape[1] > 500
    text = svg.read_text()
    assert "async (2 seeds)" in text and "sync-cut (2 seeds)" in text
    assert "Settings that differ" not in text and "Settings that differ" not in printed
    first = png.read_bytes(), text
    assert main([*plot, "--reference-episodes", "0"]) == 0
    assert (png.read_bytes(), svg.read_text()) == first  # redrawn byte for byte
    assert "low-level samples (ticks)" in text
    csv_text = curve_table(discover_runs([fabricated]), window=1).splitlines()
    assert csv_text[0] == "method,samples,mean,std,seeds"
    assert "async,200,65.0000,15.0000,2" in csv_text


# ----------------------------------------------------------------------------- real runs
@pytest.fixture(scope="module")
def trained_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("real") / "tool_delivery" / "async" / "seed0"
    args = ["--task", "tool_delivery", "--method", "async", "--seed", "0"]
    train_main(
        [*args, "--total-samples", "180", "--run-dir", str(run_dir), "progress=false", *TINY]
    )
    return run_dir


def test_evaluate_a_checkpoint(trained_run, tmp_path, capsys, terminal):
    trained = load_trained(trained_run)
    assert trained.path.name == "final.pt" and trained.config.method == "async"
    env = trained.make_env(0)
    try:
        first = evaluate(env, DistributionActor(trained.policy), 3, seed=5)
        again = evaluate(env, DistributionActor(trained.policy), 3, seed=5)
        sampled = evaluate(env, DistributionActor(trained.policy, greedy=False, seed=1), 3, seed=5)
    finally:
        env.close()
    assert first.returns == again.returns and first.lengths == again.lengths
    assert all(0 < n <= 40 for n in first.lengths + sampled.lengths)
    # the paper's metric averages the decision steps' rewards, whose sum is the return
    assert sum(first.option_step_rewards) == pytest.approx(sum(first.returns))
    s = sampled.summary
    assert s["episodes"] == 3 and 0.0 <= s["success_rate"] <= 1.0
    assert s["return_mean"] == pytest.approx(np.mean(sampled.returns))

    # option choices: one per choosing agent per decision point, named by the agent's options
    env = trained.make_env(0)
    try:
        choosing = []
        policy = DistributionActor(trained.policy)
        run_episode(env, lambda p: (choosing.append(p.choosing.copy()), policy(p))[1], seed=5)
        one = evaluate(env, DistributionActor(trained.policy), 1, seed=5)
    finally:
        env.close()
    counts = {a.name: int(np.sum([c[i] for c in choosing])) for i, a in enumerate(env.spec.agents)}
    assert {name: sum(c.values()) for name, c in one.choices.items()} == counts
    fetch = env.spec.agents[2]
    assert set(one.choices[fetch.name]) <= set(fetch.option_names)

    out = tmp_path / "e.json"
    main(["evaluate", "--checkpoint", str(trained_run), "--episodes", "2", "--json", str(out)])
    printed = capsys.readouterr()
    assert "| async seed0 @" in printed.out and f"\n{fetch.name}: " in printed.out
    assert "evaluating async seed0 @" in printed.err and "2/2" in printed.err  # the bar
    main(["evaluate", "--checkpoint", str(trained_run), "--episodes", "1", "--no-progress"])
    assert capsys.readouterr().err == ""
    saved = json.loads(out.read_text())
    assert saved["episodes"] == 2 and len(saved["per_episode"]["returns"]) == 2
    assert saved["source"]["policy"] == {
        "method": "async",
        "seed": 0,
        "checkpoint": str((trained_run / FINAL).resolve()),
        "samples": trained.samples,
        "greedy": True,
    }
    assert saved["source"]["env"]["max_ticks"] == 40  # the run's task settings (TINY)


def test_the_json_of_an_evaluation_records_what_produced_it(tmp_path):
    """The task and its settings as the environment was built — the robot swapped in, every
    default filled in — and who acted: a result can be traced to the robot that produced it."""
    out = tmp_path / "result.json"
    reference = ["evaluate", "--reference", "random", "--task", "tool_delivery"]
    settings = ["env.turtlebot_robot=diffbot", "env.max_ticks=20"]
    assert (
        main([*reference, *settings, "--episodes", "1", "--no-progress", "--json", str(out)]) == 0
    )
    source = json.loads(out.read_text())["source"]
    assert (source["task"], source["strategy"]) == ("tool_delivery", "continue")
    assert source["env"]["turtlebot_robot"] == "diffbot" and source["env"]["max_ticks"] == 20
    assert source["env"]["fetch_robot"] == "fetch"  # a default, recorded too
    assert source["policy"] == {"reference": "random"} and isinstance(source["plugins"], list)


def test_evaluate_a_mac_dqn_checkpoint_made_by_the_grid(tmp_path, capsys):
    cell = Cell("tool_delivery", "mac-dqn", 0)
    grid = dict(tasks=["tool_delivery"], methods=["mac-dqn"], seeds=[0], in_process=True)
    outcomes = run_grid(tmp_path, overrides=[*TINY_DQN, "total_samples=120"], **grid)
    assert outcomes == {cell: "done"}
    run_dir = cell.run_dir(tmp_path.resolve())
    assert not (run_dir / "rollout.mp4").exists()  # the grid records no videos

    trained = load_trained(run_dir)
    assert trained.config.method == "mac-dqn" and trained.samples >= 120
    greedy = trained.actor(greedy=True)
    assert isinstance(greedy, QActor) and greedy.epsilon == 0.0
    env = trained.make_env(0)
    try:
        first = evaluate(env, greedy, 3, seed=5)
        again = evaluate(env, trained.actor(greedy=True), 3, seed=5)
        explore = evaluate(env, trained.actor(greedy=False, seed=1), 3, seed=5)
    finally:
        env.close()
    assert first.returns == again.returns and first.lengths == again.lengths
    assert all(0 < n <= 40 for n in first.lengths + explore.lengths)
    assert trained.actor(greedy=False).epsilon == trained.config.learner.eps_end
    assert trained.label(greedy=False) == "mac-dqn seed 0 (ε-greedy)"  # a video's title
    assert trained.label() == "mac-dqn seed 0 (greedy)"

    main(["evaluate", "--checkpoint", str(run_dir), "--episodes", "2", "--sample"])
    assert "| mac-dqn seed0 @" in capsys.readouterr().out


@pytest.mark.parametrize("method", ["acac", "mac-iaicc"])
def test_evaluate_a_committed_checkpoint_of_the_literatures_methods(method, tmp_path, capsys):
    """The 6x6 Box Pushing study's seed-0 weights of ACAC and Mac-IAICC (trained at their
    published settings, committed): the evaluate command loads them and their sampled policy
    delivers the big box in 6 ticks, every agent choosing its side of it and pushing."""
    committed = Path(__file__).parents[2] / "results/box-pushing-6/runs/box_pushing_grid"
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    for name in (FINAL, "config.json"):
        (run_dir / name).write_bytes((committed / method / "seed0" / name).read_bytes())
    main(["evaluate", "--checkpoint", str(run_dir), "--episodes", "2", "--sample"])
    out = capsys.readouterr().out
    assert f"| {method} seed0 @" in out and "| 299.4 ± 0.0 | 100% | 6.0 ± 0.0 |" in out, out
    assert "agent0: 4 choices — GoToBigBox(left) 50%, Push 50%" in out, out
    assert "agent1: 4 choices — GoToBigBox(right) 50%, Push 50%" in out, out


def _frames(path: Path) -> list[np.ndarray]:
    reader = imageio.get_reader(path)
    try:
        return list(reader.iter_data())
    finally:
        reader.close()


def test_video_of_a_checkpoint(trained_run, tmp_path, capsys, monkeypatch, terminal):
    out = tmp_path / "trained.mp4"
    titles = []
    monkeypatch.setattr(video, "video_title", lambda *a: titles.append(a) or video_title(*a))
    main(["video", "--checkpoint", str(trained_run), "--out", str(out), "--seed", "3"])
    printed = capsys.readouterr()
    ticks = int(printed.out.split(" in ")[1].split(" ticks")[0])
    assert len(_frames(out)) == 4 * ticks + 1
    assert "video trained.mp4" in printed.err  # the progress bar
    # the title names the checkpoint's method and training seed apart from the episode's seed
    assert titles == [("tool_delivery", "continue", "async seed 0 (greedy)", 3)]
    # sampled options are seeded too: the same seed films the same episode
    args = ["video", "--checkpoint", str(trained_run), "--sample", "--seed", "4", "--out"]
    main([*args, str(tmp_path / "a.mp4"), "--no-progress"])
    assert titles[-1][2] == "async seed 0 (sampled)" and capsys.readouterr().err == ""
    main([*args, str(tmp_path / "b.mp4")])
    a, b = _frames(tmp_path / "a.mp4"), _frames(tmp_path / "b.mp4")
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_a_checkpoint_evaluates_and_films_in_other_looks(trained_run, tmp_path, capsys):
    """Task settings over the run's own where its policy can act (``env.appearance``): a
    policy from state plays the same episode in every look, which the evaluation records and
    the film shows; a setting that changes its agents is refused in one line, nothing
    written."""
    results, films = {}, {}
    for look in ("off", "heldout"):
        path = tmp_path / f"{look}.json"
        argv = ["evaluate", "--checkpoint", str(trained_run), "--episodes", "1", "--no-progress"]
        assert main([*argv, "--json", str(path), f"env.appearance={look}"]) == 0
        results[look] = json.loads(path.read_text())
        film = tmp_path / f"{look}.mp4"
        argv = ["video", "--checkpoint", str(trained_run), "--out", str(film), "--no-progress"]
        assert main([*argv, f"env.appearance={look}", "env.max_ticks=2"]) == 0
        films[look] = _frames(film)
    assert results["heldout"]["source"]["env"]["appearance"] == "heldout"
    assert results["heldout"]["per_episode"] == results["off"]["per_episode"]
    assert len(films["off"]) == len(films["heldout"])
    assert not np.array_equal(films["off"][0], films["heldout"][0])
    capsys.readouterr()
    out = tmp_path / "refused.json"
    argv = ["evaluate", "--checkpoint", str(trained_run), "--json", str(out), "env.turtlebots=3"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "env.turtlebots=3: the checkpoint's policy cannot act" in err
    assert not out.exists()


def test_timeline_of_a_checkpoint(trained_run, tmp_path, capsys, monkeypatch):
    out = tmp_path / "plots" / "trained.svg"
    titles = []
    draw = timeline.draw_figure
    monkeypatch.setattr(timeline, "draw_figure", lambda *a: titles.append(a[3]) or draw(*a))
    main(["timeline", "--checkpoint", str(trained_run), "--out", str(out), "--seed", "3"])
    assert f"{out}: options of 3 agents over" in capsys.readouterr().out
    assert out.read_text().lstrip().startswith("<?xml")
    assert "| async seed 0 (greedy) | episode seed 3: return" in titles[0]


def test_table_and_plot_commands_on_a_real_run(trained_run, tmp_path, capsys, terminal):
    runs = discover_runs([trained_run.parents[2]])
    assert len(runs) == 1 and runs[0].finished and runs[0].samples[-1] >= 180
    root = str(trained_run.parents[2])
    assert main(["table", root, "--window", "1"]) == 0
    printed = capsys.readouterr().out
    peak_return = peak(runs[0])
    assert f"| tool_delivery | async | 1 | {peak_return:.1f} |" in printed
    assert main(["plot", root, "--out", str(tmp_path), "--reference-episodes", "2"]) == 0
    assert "evaluating scripted" in capsys.readouterr().err  # the reference policies' bar
    svg = (tmp_path / "curves_tool_delivery.svg").read_text()
    assert "async (1 seed)" in svg and "scripted (" in svg and "random (" in svg
    assert imageio.imread(tmp_path / "curves_tool_delivery.png").ndim == 3
    assert [p.suffix for p in plot_all(runs, tmp_path)] == [".png", ".svg"]


# ----------------------------------------------------------------------------- the grid
def test_grid_skips_finished_runs_and_resumes_unfinished_ones(tmp_path):
    runs_root, results = tmp_path / "runs", tmp_path / "results"
    overrides = [*TINY, "total_samples=120"]
    grid = dict(tasks=["tool_delivery"], seeds=[0, 1], overrides=overrides, in_process=True)

    # seed 0 finished earlier; seed 1 was cut off after its first iteration (60 samples)
    outcomes = run_grid(runs_root, methods=["async"], **{**grid, "seeds": [0]})
    assert outcomes == {Cell("tool_delivery", "async", 0): "done"}
    seed0 = Cell("tool_delivery", "async", 0).run_dir(runs_root.resolve())
    finished_at = (seed0 / FINAL).stat().st_mtime_ns
    seed1 = Cell("tool_delivery", "async", 1).run_dir(runs_root.resolve())
    args = ["--task", "tool_delivery", "--method", "async", "--seed", "1", "--run-dir"]
    train_main([*args, str(seed1), "progress=false", *TINY, "total_samples=60"])
    (seed1 / FINAL).unlink()
    (seed1 / DONE).unlink()
    first_row = (seed1 / "metrics.csv").read_text().splitlines()[1]
    assert cell_state(seed0) == "finished" and cell_state(seed1) == "partial"

    dry = run_grid(runs_root, methods=["async"], dry_run=True, log=lambda _: None, **grid)
    assert list(dry.values()) == ["skipped", "would resume"]
    assert reproduce(runs_root, results, methods=["async"], dry_run=True, **grid)[1] == []
    assert not results.exists()  # a dry run lists, it writes no figure or table

    with pytest.raises(ValueError, match="unknown method"):  # a typo is not an empty grid
        run_grid(runs_root, methods=["async", "asnyc"], **grid)
    assert main(["reproduce", "--runs", str(runs_root), "--methods", "asnyc", "--dry-run"]) == 2
    outcomes, written = reproduce(
        runs_root, results, methods=["async"], reference_episodes=1, **grid
    )
    assert outcomes == {
        Cell("tool_delivery", "async", 0): "skipped",
        Cell("tool_delivery", "async", 1): "done",
    }
    assert (seed0 / FINAL).stat().st_mtime_ns == finished_at  # not retrained
    rows = (seed1 / "metrics.csv").read_text().splitlines()
    assert rows[1] == first_row  # continued from its checkpoint, not restarted
    assert int(rows[-1].split(",")[1]) >= 120 and cell_state(seed1) == "finished"
    names = {p.name for p in written}
    assert {"curves_tool_delivery.png", "fig4_tool_delivery.svg", "tables.md"} <= names
    tables = (results / "tables.md").read_text()
    assert "| tool_delivery | async | 2 |" in tables
    assert "Table I analog" not in tables  # async alone: no paper table to put it beside

    # a second invocation has nothing left to train
    again = run_grid(runs_root, methods=["async"], log=lambda _: None, **grid)
    assert set(again.values()) == {"skipped"}

    # the command regenerates the results, evaluation included, without training
    argv = ["reproduce", "--runs", str(runs_root), "--results", str(results), "--no-train"]
    argv += ["--reference-episodes", "1"]
    (results / "tables.md").unlink()
    assert main([*argv, "--tasks", "tool_delivery", "--eval-episodes", "1"]) == 0
    assert (results / "tables.md").read_text() == tables
    evaluation = (results / "evaluation.md").read_text()
    for strategy in ("continue", "any", "all"):
        assert f"| scripted | tool_delivery | {strategy} | 1 |" in evaluation
        assert f"| random | tool_delivery | {strategy} | 1 |" in evaluation
    assert "| async seed0 greedy | tool_delivery | continue | 1 |" in evaluation
    assert "| async seed0 sampled | tool_delivery | continue | 1 |" in evaluation
    # evaluations are cached per run, keyed on the behaviours and the weights they rest on
    cache = seed0 / "evaluation.json"
    cached = json.loads(cache.read_text())
    policy = type(load_trained(seed0 / FINAL).policy)
    assert {**cached["key"], "weights": None} == {
        "episodes": 1,
        **behaviour(["tool_delivery"], policy),
        "weights": None,
    }
    cached["results"][0]["label"] = "from the cache"
    cache.write_text(json.dumps(cached))
    assert main([*argv, "--eval-episodes", "1"]) == 0
    assert "| from the cache |" in (results / "evaluation.md").read_text()
    cached["key"]["weights"] = "0" * 64  # as if final.pt had been retrained since
    cache.write_text(json.dumps(cached))
    assert main([*argv, "--eval-episodes", "1"]) == 0
    assert "| from the cache |" not in (results / "evaluation.md").read_text()
    # ... and redone for another episode count
    assert main([*argv, "--eval-episodes", "2"]) == 0
    assert (
        "| async seed0 greedy | tool_delivery | continue | 2 |"
        in (results / "evaluation.md").read_text()
    )


def test_the_default_grid_is_the_committed_one(tmp_path):
    """Per-task seeds (Water Filling: 3) and Water Filling Mac-DQN's smaller replay, declared by
    the paper's study; a user's setting wins over the study's."""
    dry = run_grid(tmp_path, methods=["async", "mac-dqn"], dry_run=True, log=lambda _: None)
    paper = get_study("paper")
    for task in ("tool_delivery", "water_filling"):
        seeds = sorted({c.seed for c in dry if c.task == task})
        assert seeds == list(paper.task(task).seeds)
    assert set(dry.values()) == {"would start"}
    wf, _ = cell_config(Cell("water_filling", "mac-dqn", 0), tmp_path, paper)
    assert wf.learner.buffer_size == 10_000
    mine, _ = cell_config(
        Cell("water_filling", "mac-dqn", 0), tmp_path, paper, ["dqn.buffer_size=20000"]
    )
    assert mine.learner.buffer_size == 20_000
    td, resume = cell_config(Cell("tool_delivery", "mac-dqn", 0), tmp_path, paper)
    assert td.learner.buffer_size != 10_000 and not resume
    with pytest.raises(ValueError, match="seed=3 contradicts the grid's cell"):
        cell_config(Cell("tool_delivery", "async", 0), tmp_path, paper, ["seed=3"])


def test_each_committed_run_is_the_config_its_study_builds():
    """The grid builds every committed run's config from its study's typed settings as the run
    saved it, in every setting that changes what is computed (a run may have been trained with
    a video, say: ``RESUMABLE_KEYS``). The runs trained from argv strings before the grid built
    configs, so the same grid reproduces the same runs, and a partial one resumes."""
    checked = 0
    for name in study_names():
        study = get_study(name)
        root = study.runs_dir()
        for run in discover_runs([root]) if root.exists() else []:
            if run.method not in study.methods or run.seed not in study.task(run.task).seeds:
                continue  # a pilot kept beside the grid
            cell = Cell(run.task, run.method, run.seed)
            built, _ = cell_config(cell, root.resolve(), study)
            saved = TrainConfig.load(run.path / "config.json")
            learnt = [
                {k: v for k, v in c.resolved().flat().items() if k not in RESUMABLE_KEYS}
                for c in (built, saved)
            ]
            assert learnt[0] == learnt[1], run.path
            # the budget is resumable (a run may be extended), not free: the study sets it
            assert built.resolved().total_samples == saved.resolved().total_samples, run.path
            checked += 1
    assert checked >= 40


def test_grid_runs_train_as_a_subprocess(tmp_path):
    outcomes = run_grid(
        tmp_path,
        tasks=["tool_delivery"],
        methods=["sync-wait"],
        seeds=[3],
        overrides=[*TINY, "total_samples=60"],
        log=lambda _: None,
    )
    assert outcomes == {Cell("tool_delivery", "sync-wait", 3): "done"}
    run_dir = Cell("tool_delivery", "sync-wait", 3).run_dir(tmp_path.resolve())
    config = json.loads((run_dir / "config.json").read_text())
    assert (config["method"], config["seed"], config["batch_ticks"]) == ("sync-wait", 3, 60)
    assert cell_state(run_dir) == "finished"


def test_a_registered_study_runs_its_settings_and_scores_against_its_own_references(
    tmp_path, monkeypatch
):
    """A study's task settings reach every run and the reference policies; its normalised
    score is (R − R_random) / (R_scripted − R_random) with the references at those settings."""
    settings = {"max_ticks": 40, "human_stage_ticks": 9}
    study = Study(
        "tiny-test",
        "a shorter Tool Delivery",
        (StudyTask("tool_delivery", (0,), settings),),
        ("async",),
        overrides=frozen(
            {"batch_ticks": 60, "num_envs": 2, "plot": False, "ppo.epochs": 2, "total_samples": 120}
        ),
        normalised=True,
    )
    monkeypatch.setattr(registry, "_STUDIES", dict(registry._STUDIES))  # registered here only
    register_study(study.name, lambda: study)
    assert study.runs_dir() == Path("results/tiny-test/runs")
    with pytest.raises(ValueError, match="not in study 'tiny-test'"):
        run_grid(tmp_path, study="tiny-test", tasks=["water_filling"])
    runs_root, results = tmp_path / "runs", tmp_path / "results"
    outcomes, _ = reproduce(
        runs_root,
        results,
        study="tiny-test",
        in_process=True,
        eval_episodes=0,
        reference_episodes=2,
    )
    assert list(outcomes.values()) == ["done"]
    config = json.loads((runs_root / "tool_delivery/async/seed0/config.json").read_text())
    assert config["env_overrides"] == settings
    reference = json.loads((results / "reference.json").read_text())
    assert reference["key"]["settings"] == {"tool_delivery": settings}
    levels = {
        r["label"]: r["return_mean"] for r in reference["results"] if r["strategy"] == "continue"
    }
    (run,) = discover_runs([runs_root])
    score = (final(run) - levels["random"]) / (levels["scripted"] - levels["random"])
    assert (
        f"| tool_delivery | async | 1 | {final(run):.1f} | {score:.2f} |"
        in (results / "tables.md").read_text()
    )
    # A study of a variant reads the paper's runs of its baselines beside its own, untrained.
    tasks = (StudyTask("tool_delivery", (0,)),)
    variant = Study("variant", "-", tasks, ("async-ar",), baselines=("async",))
    with pytest.raises(ValueError, match="baselines come from the paper's runs"):
        Study("bad", "-", study.tasks, ("async-ar",), baselines=("async",))
    reproduce(
        tmp_path / "variant_runs",
        tmp_path / "variant",
        study=variant,
        train=False,
        eval_episodes=0,
        baseline_root=runs_root,
    )
    assert "| tool_delivery | async | 1 |" in (tmp_path / "variant" / "tables.md").read_text()


@pytest.mark.parametrize("name", study_names())
def test_every_registered_study_plans_runs_that_train_accepts(tmp_path, name):
    """Each cell's command line (task settings, budgets, method presets) is read as train
    reads it before anything runs (``check_cells``), so a dry run proves every cell starts."""
    dry = run_grid(tmp_path, study=name, dry_run=True, log=lambda _: None)
    study = get_study(name)
    assert set(dry.values()) == {"would start"}
    assert len(dry) == len(study.methods) * sum(len(t.seeds) for t in study.tasks)


def test_an_agents_options_are_named_by_their_shares_of_its_choices():
    assert (
        option_shares({"b": 1, "a": 1, "c": 6, "d": 2}, 2) == "10 choices — c 60%, d 20%, other 20%"
    )
    assert option_shares({"b": 1, "a": 1, "z": 0}) == "2 choices — a 50%, b 50%"  # name order
    assert option_shares({"a": 999, "b": 1}) == "1000 choices — a 100%, b <1%"
    assert option_shares({}) == "no choice"
