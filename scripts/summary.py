"""The main job's last words (``scripts/run.sh``): what the run learnt and where everything is.

Run: ``.venv/bin/python scripts/summary.py RUN_DIR``. Reads the run's ``done.json`` (samples,
training time, final return) and the evaluations ``scripts/run.sh`` wrote beside it
(``eval_greedy.json``, ``eval.json`` with sampled options); prints their figures, then every
file of the run directory with what it is for. Exit status 1 when the run is unfinished or an
evaluation is missing.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from maopg.experiment.run import directory

EVALUATIONS = {"greedy": "eval_greedy.json", "sampled": "eval.json"}
"""How the policy acted → the file ``scripts/run.sh`` wrote its evaluation to."""

FILES = {
    directory.CONFIG: "the resolved settings (python -m train --config takes it)",
    directory.METRICS: "one row per training iteration",
    directory.TENSORBOARD: "TensorBoard logs: tensorboard --logdir {dir}",
    directory.CHECKPOINT: "everything to resume or extend the run (--resume)",
    directory.FINAL: "the trained policy: python -m eval evaluate|video --checkpoint {dir}, "
    "or load_policy('{dir}') in Python",
    directory.CURVE: "the learning curve",
    directory.VIDEO: "an episode of the trained policy (options sampled)",
    directory.DONE: "the finished run's counts, final return and evaluation",
    **{name: f"the {kind} policy's evaluation" for kind, name in EVALUATIONS.items()},
}
"""What each file of a main-job run directory is."""


def summary(run_dir: Path) -> str:
    """The summary's lines (raises ``FileNotFoundError`` for a missing record)."""
    done = json.loads((run_dir / directory.DONE).read_text())
    lines = [f"main job finished: {run_dir}"]
    final = done.get("final_return")
    final = "none (no episode ended)" if final is None else f"{final:.1f}"
    lines.append(
        f"  trained {done['samples']:,} samples in {done['wall_time']:.0f} s of training; "
        f"final return {final} (the training episodes of its last 10% of samples)"
    )
    for kind, name in EVALUATIONS.items():
        result = json.loads((run_dir / name).read_text())
        lines.append(
            f"  {kind:7} policy: return {result['return_mean']:.1f}, "
            f"success {result['success_rate']:.0%} over {result['episodes']} episodes ({name})"
        )
    lines.append("  files:")
    for path in sorted(run_dir.iterdir()):
        about = FILES.get(path.name)
        if about is not None:
            shown = f"{path.name}/" if path.is_dir() else path.name
            lines.append(f"    {shown:20} {about.format(dir=run_dir)}")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: python scripts/summary.py RUN_DIR", file=sys.stderr)
        return 2
    try:
        print(summary(Path(argv[0])))
    except FileNotFoundError as err:
        print(f"summary: {err.filename} is missing: the main job did not finish", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
