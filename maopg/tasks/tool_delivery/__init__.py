"""Tool Delivery (docs/DESIGN.md §7): registration of the task and what the project needs to
know about it. The modules are imported lazily, on first use of the entry."""

from __future__ import annotations

from maopg.tasks.registry import register_task

register_task(
    "tool_delivery",
    f"{__name__}.task:ToolDelivery",
    config=f"{__name__}.config:Config",
    scripted=f"{__name__}.scripted:scripted_policy",
    panel=f"{__name__}.display:panel",
    # The paper's batch size in low-level samples; the budget covers its curves.
    train_defaults={"batch_ticks": 200, "total_samples": 100_000, "images": False},
)
