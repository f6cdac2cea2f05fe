"""Box Pushing in MuJoCo (issue #43): the grid benchmark with physical robots and boxes.
Registration of the task and what the project needs to know about it; the modules are imported
lazily, on first use of the entry."""

from __future__ import annotations

from maopg.tasks.box_pushing_grid import EXPLORATION
from maopg.tasks.registry import register_task

register_task(
    "box_pushing",
    f"{__name__}.task:BoxPushing",
    config=f"{__name__}.config:Config",
    # The grid's reference policy itself: it reads option names and the big-box bit, which
    # this task shares with the grid (maopg/tasks/box_pushing/task.py).
    scripted="maopg.tasks.box_pushing_grid.scripted:scripted_policy",
    panel=f"{__name__}.display:panel",
    # The grid's budget, batches and exploration (``EXPLORATION``): the same decisions over
    # episodes as long, so the two tasks' studies differ in the physics alone.
    train_defaults={"batch_ticks": 1000, "total_samples": 500_000, "images": False, **EXPLORATION},
)
