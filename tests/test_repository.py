"""What the repository keeps: weights only where a study's committed results are made from them.

A study's videos and ``evaluation.md`` (and the leaderboard's account of what its policies do)
read the seed-0 ``final.pt`` of each of its methods; every other run's weights, and every
pilot's, stay local (``.gitignore``) — the history keeps those committed before this rule. A
clone stays light, and what it carries is what it needs.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from maopg.experiment.studies import get_study, study_names
from maopg.experiment.studies.leaderboard import AGENT_METHODS, BOARDS, CONDITIONAL
from maopg.experiment.studies.registry import LEADERBOARD, VISION
from maopg.experiment.studies.vision import METHOD, VARIANTS

ROOT = Path(__file__).resolve().parents[1]


def _tracked(pattern: str) -> list[Path]:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run(
        ["git", "ls-files", pattern], cwd=ROOT, capture_output=True, text=True, check=True
    )
    return [Path(line) for line in out.stdout.splitlines()]


def allowed_weights() -> set[Path]:
    """Seed 0's ``final.pt`` of every method of every registered study (and of the paper's
    runs a study reads as its baselines), of every variant of the vision study, and of the
    leaderboard's own cells of the headline's methods (what their policies do is read from
    them)."""
    allowed = set()
    for name in study_names():
        study = get_study(name)
        for task in study.tasks:
            if 0 not in task.seeds:
                continue
            for method in study.methods:
                allowed.add(study.runs_dir() / task.task / method / "seed0" / "final.pt")
    for variant in VARIANTS:  # the vision study's runs, a variant a folder
        runs = Path("results", VISION, "runs", variant.name)
        for task in variant.study.tasks:
            if 0 in task.seeds:
                allowed.add(runs / task.task / METHOD / "seed0" / "final.pt")
    own = Path("results", LEADERBOARD, "runs")
    for board in BOARDS:
        for _, runs, methods in board.grids(own):
            if runs.is_relative_to(own):
                read = [m for m in methods if m in (*CONDITIONAL, *AGENT_METHODS)]
                allowed |= {runs / board.task / m / "seed0" / "final.pt" for m in read}
    return allowed


def test_only_the_weights_a_study_reads_are_committed():
    extra = sorted(str(p) for p in _tracked("*.pt") if p not in allowed_weights())
    assert not extra, f"weights no study's results read are committed: {extra}"
