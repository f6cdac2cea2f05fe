"""The vision study (maopg.experiment.studies.vision): its variants are the issue's, and a tiny
one trains, evaluates each policy in its own looks and in held-out ones, writes its tables, and
redraws them from the cached evaluations once the weights are gone (a clean clone)."""

from __future__ import annotations

import csv
import json
from dataclasses import replace

from maopg.env.vector_base import episode_seed
from maopg.experiment.studies import StudyTask, frozen
from maopg.experiment.studies.grid import Cell, cell_config
from maopg.experiment.studies.vision import (
    EPISODES,
    EVALUATION,
    FULL_VARIANT,
    OFF_VARIANT,
    PRIMARY_ACTING,
    VARIANTS,
    Outcome,
    Variant,
    reproduce_vision,
    targets_table,
    variant,
)


def test_the_variants_are_the_issues(tmp_path):
    """RGB ``async`` trained with ``off`` and ``full`` on both tasks at their budgets, 3 seeds;
    depth and RGB+depth pilots on Tool Delivery, one seed, trained with ``full``."""
    seen = {}
    for v in VARIANTS:
        for study_task in v.study.tasks:
            config = cell_config(Cell(study_task.task, "async", 0), tmp_path, v.study)[0]
            env = config.env().overrides
            seen[v.name, study_task.task] = (
                env["appearance"],
                env["camera_channels"],
                config.images,
                config.total_samples,
                study_task.seeds,
                v.pilot,
            )
    assert seen == {
        ("off", "tool_delivery"): ("off", "rgb", True, 100_000, (0, 1, 2), False),
        ("off", "water_filling"): ("off", "rgb", True, 200_000, (0, 1, 2), False),
        ("full", "tool_delivery"): ("full", "rgb", True, 100_000, (0, 1, 2), False),
        ("full", "water_filling"): ("full", "rgb", True, 200_000, (0, 1, 2), False),
        ("depth", "tool_delivery"): ("full", "depth", True, 100_000, (0,), True),
        ("rgb-depth", "tool_delivery"): ("full", "rgb+depth", True, 100_000, (0,), True),
    }


def test_the_evaluations_play_no_training_episode(tmp_path):
    """The evaluations reset with seeds 0 to 19, which no run of the study resets a training
    episode with in its first 5,000 episodes per environment (Tool Delivery's 100K samples over
    4 environments hold that many only at 5 ticks an episode, Water Filling's 200K at 10)."""
    runs = set()
    for v in VARIANTS:
        for study_task in v.study.tasks:
            config = cell_config(Cell(study_task.task, "async", 0), tmp_path, v.study)[0]
            runs |= {(seed, config.resolved().num_envs) for seed in study_task.seeds}
    training = {
        episode_seed(seed, env, episode)
        for seed, envs in runs
        for env in range(envs)
        for episode in range(5_000)
    }
    assert not training & set(range(EPISODES))


TINY = frozen(
    {
        "total_samples": 120,
        "batch_ticks": 60,
        "num_envs": 1,
        "backend": "local",
        "image_size": 36,
        "plot": False,
    }
)
"""Two iterations of one environment's 36-pixel frames."""


def _tiny(name: str, appearance: str, channels: str = "rgb", pilot: bool = False) -> Variant:
    """A variant of the study's own making, shrunk: 12-tick episodes, the budget above."""
    made = variant(name, appearance, channels, tasks=("tool_delivery",), seeds=(0,), pilot=pilot)
    (task,) = made.study.tasks
    settings = frozen({**task.settings, "max_ticks": 12})
    tiny = StudyTask(task.task, task.seeds, settings, TINY)
    return Variant(name, replace(made.study, tasks=(tiny,)), pilot)


def test_a_tiny_vision_study_trains_evaluates_and_redraws_without_weights(tmp_path):
    variants = [_tiny(OFF_VARIANT, "off"), _tiny(FULL_VARIANT, "full")]
    variants.append(_tiny("depth", "full", "depth", pilot=True))
    out = tmp_path / "vision"
    kw = {"variants": variants, "episodes": 2, "reference_episodes": 2, "log": lambda _: None}
    cells, written = reproduce_vision(out, in_process=True, **kw)
    assert sorted(cells.values()) == ["done"] * 3
    assert {p.name for p in written} == {
        "tables.md",
        "scores.csv",
        "curves_tool_delivery.png",
        "curves_tool_delivery.svg",
    }
    for name, look in (("off", "off"), ("full", "full"), ("depth", "full")):
        run = out / "runs" / name / "tool_delivery" / "async" / "seed0"
        evaluated = json.loads((run / EVALUATION).read_text())["results"]
        assert [(s["look"], s["acting"], s["episodes"]) for s in evaluated] == [
            (look, "greedy", 2),
            (look, "sampled", 2),
            ("heldout", "greedy", 2),
            ("heldout", "sampled", 2),
            ("mounts", "greedy", 2),
            ("mounts", "sampled", 2),
        ]
    with (out / "scores.csv").open(newline="") as handle:
        scores = list(csv.DictReader(handle))
    assert [(r["variant"], r["acting"], r["trained_look"]) for r in scores] == [
        ("off", "greedy", "off"),
        ("off", "sampled", "off"),
        ("full", "greedy", "full"),
        ("full", "sampled", "full"),
        ("depth", "greedy", "full"),
        ("depth", "sampled", "full"),
    ]
    text = (out / "tables.md").read_text()
    targets = [line for line in text.splitlines() if line.startswith("| tool_delivery | ")]
    targets = [line for line in targets if " vs " in line]
    assert [line.split(" | ")[:3] for line in targets] == [
        ["| tool_delivery", "greedy (reported)", "1 / 1 of 1"],
        ["| tool_delivery", "sampled (primary)", "1 / 1 of 1"],
    ]
    assert "| depth (pilot) | full | depth | greedy | 1 |" in text
    assert "| water_filling |" not in text  # a task no variant trains has no rows
    # A clean clone keeps no weights: the cached evaluations stand for them, unchanged.
    for weights in out.rglob("final.pt"):
        weights.unlink()
    again, rewritten = reproduce_vision(out, train=False, **kw)
    assert again == {} and {p.name for p in rewritten} == {p.name for p in written}
    assert (out / "tables.md").read_text() == text
    # ... unless they measured looks drawn otherwise than now: then they stand for nothing
    stale = out / "runs" / "off" / "tool_delivery" / "async" / "seed0" / EVALUATION
    saved = json.loads(stale.read_text())
    saved["key"]["looks_version"] -= 1
    stale.write_text(json.dumps(saved))
    reproduce_vision(out, train=False, **kw)
    redrawn = (out / "tables.md").read_text()
    assert "not evaluated" not in text and "| off | off | rgb | greedy | 1 | — |" in redrawn
    assert redrawn.count("seed0 not evaluated") == 2  # greedy and sampled


def _outcome(name: str, seed: int, acting: str, own: float, heldout: float) -> Outcome:
    look = "off" if name == OFF_VARIANT else "full"
    scores = (own, heldout, own)  # mounts: no target reads it
    return Outcome(name, "tool_delivery", seed, acting, look, *scores, *scores, 20)


def test_the_targets_count_their_seeds_and_refuse_a_base_at_random():
    """Each target row says how many seeds its means stand on (provisional short of all), the
    verdict's acting is marked, and a base not above random gives no verdict."""
    rows = [_outcome(OFF_VARIANT, s, a, 0.6, 0.2) for s in range(3) for a in ("greedy", "sampled")]
    rows += [_outcome(FULL_VARIANT, s, "sampled", 0.55, 0.5) for s in range(2)]
    rows += [_outcome(FULL_VARIANT, s, "greedy", 0.3, 0.1) for s in range(3)]
    greedy, sampled = targets_table(["tool_delivery"], rows).splitlines()[2:]
    assert PRIMARY_ACTING == "sampled" and "sampled (primary)" in sampled
    assert "3 / 2 of 3 (provisional)" in sampled and "3 / 3 of 3 |" in greedy
    assert "0.55 vs 0.8 × 0.60 = 0.48: **met**" in sampled
    assert "0.50 vs 0.9 × 0.55 = 0.50: **met**" in sampled
    assert "0.30 vs 0.8 × 0.60 = 0.48: **missed**" in greedy
    at_random = [_outcome(OFF_VARIANT, 0, "sampled", -0.1, -0.2)]
    at_random.append(_outcome(FULL_VARIANT, 0, "sampled", -0.3, -0.4))
    row = targets_table(["tool_delivery"], at_random, {"tool_delivery": 1}).splitlines()[3]
    assert row.count("no verdict (the base is not above random)") == 2
    assert "**met**" not in row and "**missed**" not in row
