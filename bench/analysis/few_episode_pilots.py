"""The pilots behind ACAC's and Mac-IAICC's few-episode settings (the leaderboard's settings of
both on the tasks whose budgets hold hundreds of episodes:
``maopg.experiment.studies.builtin.FEW_EPISODES``): Tool Delivery from state, 30K samples, 3
seeds each, one setting changed at a time. Each run is persisted in
``results/leaderboard/pilots/<pilot>/seed<k>`` (config, metrics, ``done.json``; weights stay
local), so ``run`` resumes where a session stopped and ``table`` regenerates the pilot table from
the logged runs.

    python bench/analysis/few_episode_pilots.py run [PILOT ...]
    python bench/analysis/few_episode_pilots.py table > results/leaderboard/pilots.md

Every run evaluates every 10K samples (10 episodes sampled from the policy, never mixed with
exploration); the table gives each seed's evaluation at 10K, 20K and 30K beside a random
team's mean over 40 episodes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pilot_runs import commands_text, finished, pilot_main, train_command, train_runs

from maopg.env.rollout import evaluate_reference
from maopg.experiment.run.directory import read_metrics
from maopg.experiment.studies.builtin import FEW_EPISODES

ROOT = Path("results/leaderboard/pilots")
SEEDS = (0, 1, 2)
BUDGET = 30_000
COMMON = {
    "eval_every": 10_000,
    "eval_during_episodes": 10,
    "eval_episodes": 0,
    "video": False,
    "plot": False,
    "progress": False,
}


@dataclass(frozen=True)
class Pilot:
    method: str
    about: str
    settings: dict[str, Any]

    def command(self, name: str, seed: int) -> list[str]:
        """The ``train`` command line of the pilot ``name``'s seed."""
        run_dir = ROOT / name / f"seed{seed}"
        settings = {**COMMON, **self.settings}
        return train_command("tool_delivery", self.method, seed, BUDGET, run_dir, settings)


PILOTS = {
    "acac-rounds-4": Pilot(
        "acac",
        "ACAC's published update (clip 0.05, 2 epochs, rates 3e-4) in rounds of 4 episodes, ε over "
        "100 episodes",
        {"acac.episodes_per_update": 4, "acac.explore_decay": 100},
    ),
    "acac-ppo": Pilot(
        "acac",
        "as `acac-rounds-4`, ε over 50 episodes, updated as maopg's PPO (clip 0.2, 10 epochs, "
        "rates 5e-4): the few-episode settings",
        dict(FEW_EPISODES["acac"]),
    ),
    "maciaicc-rounds-4": Pilot(
        "mac-iaicc",
        "MacroMARL's Box Pushing settings (one-step targets, rates 3e-4 and 3e-3) in rounds of 4 "
        "episodes, ε over 100 episodes",
        {"maciaicc.episodes_per_update": 4, "maciaicc.explore_decay": 100},
    ),
    "maciaicc-fast": Pilot(
        "mac-iaicc",
        "one-step targets, actor rate 1e-3, rounds of 2 episodes, ε over 50 episodes",
        {
            "maciaicc.episodes_per_update": 2,
            "maciaicc.explore_decay": 50,
            "maciaicc.lr": 1e-3,
        },
    ),
    "maciaicc-warehouse": Pilot(
        "mac-iaicc",
        "MacroMARL's Warehouse settings (5-step targets, rates 5e-4 and 5e-4, rounds of 4, "
        "targets every 32 episodes), ε over 50 episodes: the few-episode settings",
        dict(FEW_EPISODES["mac-iaicc"]),
    ),
    "maciaicc-warehouse-1": Pilot(
        "mac-iaicc",
        "as `maciaicc-warehouse`, rounds of 1 episode",
        {**FEW_EPISODES["mac-iaicc"], "maciaicc.episodes_per_update": 1},
    ),
    "maciaicc-warehouse-lr": Pilot(
        "mac-iaicc",
        "as `maciaicc-warehouse`, actor rate 1e-3",
        {**FEW_EPISODES["mac-iaicc"], "maciaicc.lr": 1e-3},
    ),
}


def run(names: list[str]) -> None:
    """Train every seed of the named pilots (all by default) that has not finished."""
    train_runs(
        (PILOTS[name].command(name, seed), ROOT / name / f"seed{seed}")
        for name in names or PILOTS
        for seed in SEEDS
    )


def table() -> str:
    """The pilot table from the logged runs."""
    random = [r.ret for r in evaluate_reference("tool_delivery", "random", 40, seed=0)]
    lines = [
        f"Tool Delivery (state), {BUDGET // 1000}K samples; each seed's evaluation (10 episodes, "
        f"sampled, no ε) at 10K / 20K / 30K samples. A random team: {np.mean(random):.1f} "
        "(40 episodes).",
        "",
        "| pilot | method | setting | seed 0 | seed 1 | seed 2 | mean at 30K |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, pilot in PILOTS.items():
        cells, finals = [], []
        for seed in SEEDS:
            path = ROOT / name / f"seed{seed}"
            if not finished(path):
                cells.append("—")
                continue
            values = [
                float(r["eval_return"])
                for r in read_metrics(path / "metrics.csv")
                if r["eval_return"] != "nan"
            ]
            finals.append(values[-1])
            cells.append(" / ".join(f"{v:.1f}" for v in values))
        mean = f"{np.mean(finals):.1f}" if len(finals) == len(SEEDS) else "—"
        lines.append(
            f"| `{name}` | {pilot.method} | {pilot.about} | {' | '.join(cells)} | {mean} |"
        )
    lines += commands_text({name: p.command(name, 0) for name, p in PILOTS.items()})
    return "\n".join(lines) + "\n"


def main() -> None:
    pilot_main(__doc__, PILOTS, run, table)


if __name__ == "__main__":
    main()
