"""Box Pushing on a grid, the field's macro-action benchmark as ACAC (ICML 2025) runs it:
registration of the task and what the project needs to know about it. The modules are imported
lazily, on first use of the entry."""

from __future__ import annotations

from maopg.tasks.registry import register_task

register_task(
    "box_pushing_grid",
    f"{__name__}.task:BoxPushingGrid",
    config=f"{__name__}.config:Config",
    scripted=f"{__name__}.scripted:scripted_policy",
    state_lines=f"{__name__}.display:state_lines",
    # The literature's budget (the ACAC runs stop at 500K steps). A batch holds ten horizons,
    # some thirty episodes of a random team (the reference updates on sixteen). No camera.
    train_defaults={"batch_ticks": 1000, "total_samples": 500_000, "images": False},
)
