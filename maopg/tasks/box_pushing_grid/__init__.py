"""Box Pushing on a grid, the field's macro-action benchmark as ACAC (ICML 2025) runs it:
registration of the task and what the project needs to know about it. The modules are imported
lazily, on first use of the entry."""

from __future__ import annotations

from maopg.tasks.registry import register_task

EXPLORATION = {
    "ppo.explore_eps": 1.0,
    "ppo.explore_eps_end": 0.01,
    "ppo.explore_decay": 30_000,
    "ppo.explore_unit": "episodes",
    "ppo.explore_form": "joint",
}
"""Exploration by ε-mixed sampling over the joint option, on ACAC's published schedule: the
setting under which the paper's method finds the big box at all (in 2 of 5 seeds on 6x6 and 1
of 5 on 10x10 by 200K samples, where it never does without: the pilots of
docs/results/exploration.md). Every method with a ppo section takes it, here and in the task in
MuJoCo, whose episodes are as long and its decisions the same."""

register_task(
    "box_pushing_grid",
    f"{__name__}.task:BoxPushingGrid",
    config=f"{__name__}.config:Config",
    scripted=f"{__name__}.scripted:scripted_policy",
    panel=f"{__name__}.display:panel",
    # The literature's budget (the ACAC runs stop at 500K steps). A batch holds ten horizons,
    # some thirty episodes of a random team (the reference updates on sixteen). No camera.
    train_defaults={
        "batch_ticks": 1000,
        "total_samples": 500_000,
        "images": False,
        **EXPLORATION,
    },
)
