"""Studies: named grids of runs (tasks × methods × seeds), reproduced and written up by
``python -m eval reproduce``.

- :mod:`.registry` — what a study is (:class:`Study`, :class:`StudyTask`) and the registry;
- :mod:`.builtin` — the committed studies (the paper's comparison and the questions since);
- :mod:`.grid` — bringing a study's runs to completion, resumably (:func:`run_grid`);
- :mod:`.results` — its figures, tables and evaluation (:func:`reproduce`);
- :mod:`.leaderboard` — every method on every task that supports it, on one scale;
- :mod:`.vision` — policies from cameras trained under randomised looks, evaluated in held-out
  ones;
- :mod:`.published` — Box Pushing's evaluations beside the published curves, and the
  validation of the methods that reproduce a published one;
- :mod:`.stats` — bootstrap intervals, Fisher's exact test, interquartile means, profiles;
- :mod:`.runs` — reading logged run directories (curves, finals, groups of seeds);
- :mod:`.tables`, :mod:`.plots` — result tables and learning curves from them;
- :mod:`.cache` — evaluations cached on what their numbers depend on.
"""

from __future__ import annotations

from maopg.experiment.studies.registry import (
    LEADERBOARD,
    LEADERBOARD_ABOUT,
    PAPER,
    VISION,
    VISION_ABOUT,
    Study,
    StudyTask,
    declared_thresholds,
    frozen,
    get_study,
    register_study,
    study_names,
)

# The committed studies register themselves on import (after the registry above exists).
from maopg.experiment.studies import builtin  # noqa: F401  isort: skip

__all__ = [
    "LEADERBOARD",
    "LEADERBOARD_ABOUT",
    "PAPER",
    "VISION",
    "VISION_ABOUT",
    "Study",
    "StudyTask",
    "declared_thresholds",
    "frozen",
    "get_study",
    "register_study",
    "study_names",
]
