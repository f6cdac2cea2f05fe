"""What a committed run's policy did at a point of its curve, where the run kept no weights.

A run keeps its final weights only, but training is deterministic per seed on one machine: this
trains the run's saved ``config.json`` afresh to ``--samples`` (``replay_runs.train_again``,
into a folder of ``--out`` named for the run; a rerun reuses a finished one, an unfinished one
is trained again), checks that its curve repeats the committed one row for row
(``replay_runs.compare_rows``: a curve trained on another machine is not the run's, and then
neither is the policy), and plays ``--episodes`` episodes of that policy as the run's
evaluations during training acted (sampled, or greedy where it evaluated greedily; a sampled
Mac-DQN is ε-greedy at its final ε; reset seeds 0, 1, ...). Each episode prints its return,
its ticks and every agent's choices in order, repeats folded (``Push ×95``): what a dip in an
evaluation curve was.

Run: ``.venv/bin/python bench/analysis/policy_at.py RUN_DIR --samples N [--episodes 3]
[--out DIR]``.
"""

from __future__ import annotations

import argparse
import hashlib
import shutil
from itertools import groupby
from pathlib import Path

import numpy as np
from replay_runs import compare_rows, rows, train_again

from maopg.env.contract import DecisionPoint
from maopg.env.rollout import run_episode
from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import CONFIG, FINAL


def folded(names: list[str]) -> str:
    """``a, a, a, b`` → ``a ×3, b``."""
    parts = []
    for name, run in groupby(names):
        count = len(list(run))
        parts.append(name if count == 1 else f"{name} ×{count}")
    return ", ".join(parts)


def retrained(run: Path, samples: int, out: Path) -> Path:
    """``run`` trained afresh to ``samples`` under ``out``, in a folder named for the run
    directory (two studies' runs of one task, method and seed do not share it)."""
    key = hashlib.sha256(str(run.resolve()).encode()).hexdigest()[:12]
    folder = out / f"{key}-{samples}"
    config = TrainConfig.load(run / CONFIG)
    target = folder / config.task / config.method / f"seed{config.seed}"
    if not (target / FINAL).exists():
        shutil.rmtree(folder, ignore_errors=True)
        train_again(run, samples, folder)
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run", type=Path, help="a run directory with its config.json")
    parser.add_argument("--samples", type=int, required=True, help="where on the curve")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("/tmp/policy_at"))
    args = parser.parse_args()
    if not (args.run / CONFIG).exists():
        parser.error(f"no {CONFIG} in {args.run}")
    theirs = rows(args.run)
    if not 0 < args.samples <= int(theirs[-1]["samples"]):
        parser.error(f"--samples must lie within the run's {theirs[-1]['samples']} samples")
    target = retrained(args.run, args.samples, args.out)
    mine = rows(target)
    line, differs = compare_rows(theirs[: len(mine)], mine)
    print(f"{args.run} retrained to {mine[-1]['samples']} samples: the committed curve {line}")
    if differs:
        print("The policy below is not the run's.")
    trained = load_trained(target / FINAL)
    env = trained.make_env(0)
    agents = env.spec.agents
    actor = trained.actor(greedy=not trained.config.eval_during_sample, seed=0)
    try:
        for episode in range(args.episodes):
            chosen: list[list[str]] = [[] for _ in agents]

            def policy(point: DecisionPoint, chosen: list[list[str]] = chosen) -> np.ndarray:
                joint = np.asarray(actor(point))
                for i in np.flatnonzero(point.choosing):
                    chosen[i].append(agents[i].option_names[joint[i]])
                return joint

            result = run_episode(env, policy, seed=episode)
            print(f"\nepisode {episode}: return {result.ret:.1f}, {result.ticks} ticks")
            for agent, names in zip(agents, chosen, strict=True):
                print(f"- {agent.name}: {folded(names)}")
    finally:
        env.close()


if __name__ == "__main__":
    main()
