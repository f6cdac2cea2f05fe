"""The main job (``scripts/run.sh``) ends with a Tool Delivery policy that succeeds acting
greedily — how ``python -m eval`` and ``load_policy`` act by default — as well as sampled.

The test trains exactly what ``scripts/run.sh`` trains (its task, method, default seed and
sample budget, read from the script) without the video, the plot and the trainer's own final
evaluation, none of which changes the weights, then evaluates as the script does and prints its
summary. About a minute on a quiet 2-core machine: the committed Tool Delivery runs trained
100K samples in 77-114 s of training each (BENCHMARKS.md, ``bench/analysis/learning_td.py``).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from maopg.experiment.cli.eval_cli import main as eval_main
from maopg.experiment.cli.train_cli import main as train_main

REPO = Path(__file__).resolve().parents[1]
RUN_SH = (REPO / "scripts" / "run.sh").read_text()


def _default(name: str) -> int:
    """A ``NAME=${NAME:-VALUE}`` default of ``scripts/run.sh``."""
    match = re.search(rf"^{name}=\$\{{{name}:-(\d+)\}}$", RUN_SH, re.MULTILINE)
    assert match, f"scripts/run.sh sets no default {name}"
    return int(match.group(1))


@pytest.mark.slow
def test_the_main_job_ends_with_a_policy_that_succeeds_greedy_and_sampled(tmp_path):
    assert "-m train --task tool_delivery --method async --seed" in RUN_SH
    run = tmp_path / "run"
    quiet = ["video=false", "plot=false", "eval_episodes=0", "progress=false"]
    argv = ["--task", "tool_delivery", "--method", "async", "--seed", str(_default("SEED"))]
    argv += ["--total-samples", str(_default("SAMPLES")), "--run-dir", str(run), *quiet]
    assert train_main(argv) == 0
    for flag, episodes, name in (
        ("--greedy", 5, "eval_greedy.json"),
        ("--sample", 20, "eval.json"),
    ):
        args = ["evaluate", "--checkpoint", str(run), flag, "--episodes", str(episodes)]
        assert eval_main([*args, "--no-progress", "--json", str(run / name)]) == 0
        result = json.loads((run / name).read_text())
        assert result["success_rate"] >= 0.9, (flag, result["success_rate"], result["returns"])
    summary = subprocess.run(
        [sys.executable, str(REPO / "scripts" / "summary.py"), str(run)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert re.search(r"greedy  policy: return \d+\.\d, success (9\d|100)% over 5 episodes", summary)
    assert re.search(r"sampled policy: return \d+\.\d, success (9\d|100)% over 20", summary)
    assert "final.pt" in summary and "eval_greedy.json" in summary
