"""Water Filling (docs/DESIGN.md §7): registration of the task and what the project needs to
know about it. The modules are imported lazily, on first use of the entry."""

from __future__ import annotations

from maopg.tasks.registry import register_task

register_task(
    "water_filling",
    f"{__name__}.task:WaterFilling",
    config=f"{__name__}.config:Config",
    scripted=f"{__name__}.scripted:scripted_policy",
    panel=f"{__name__}.display:panel",
    # The paper's batch size in low-level samples and its image observations.
    # Environments in worker processes, one each: faster than threads here, where the drone's
    # 50 Hz Python controller takes the GIL and option steps vary in length (measured by
    # bench/perf/lockstep.py).
    train_defaults={
        "batch_ticks": 2000,
        "total_samples": 200_000,
        "images": True,
        "backend": "processes",
    },
)
