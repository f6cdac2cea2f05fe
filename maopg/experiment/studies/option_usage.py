"""What a trained policy does: its outcome and which options each agent chooses.

A return says how well a policy does, not how: two policies at the same return may split the
work between their robots, or leave one idle while the other does it all; a policy stuck below
the others may wait, or loop one short option. Each seed-0 policy (the seed whose weights a
study commits) plays ``episodes`` sampled episodes (reset seeds 0, 1, ...; as evaluations
during training act: sampled, no ε), and every agent's choices are counted by option name
(:attr:`~maopg.experiment.evaluation.evaluate.EvalResult.choices`). The summary is cached in
the run directory's ``option_usage.json``, keyed as the studies' evaluations are
(:mod:`maopg.experiment.studies.cache`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from maopg.experiment.evaluation.evaluate import evaluate, option_shares
from maopg.experiment.run.directory import FINAL
from maopg.experiment.studies.cache import cached, weights_key
from maopg.experiment.studies.runs import RunData
from maopg.experiment.studies.tables import markdown_table

OPTION_USAGE = "option_usage.json"
USAGE_EPISODES = 20
"""Sampled episodes a policy plays for its usage."""


def option_usage(run: RunData, episodes: int = USAGE_EPISODES) -> dict | None:
    """The run's final policy, sampled over ``episodes`` episodes: the evaluation summary and
    ``choices`` (agent → option → times chosen); ``None`` where the run kept no weights."""
    from maopg.experiment.evaluation.loading import load_trained

    file = run.path / FINAL
    if not file.exists():
        return None
    trained = load_trained(file)
    key = weights_key(episodes, run.task, type(trained.policy), file)

    def play() -> list[dict]:
        env = trained.make_env(0)
        try:
            label = f"{run.method} seed{run.seed} sampled"
            result = evaluate(env, trained.actor(greedy=False, seed=0), episodes, label=label)
        finally:
            env.close()
        return [{**result.summary, "choices": result.choices}]

    return cached(run.path / OPTION_USAGE, key, play)[0]


def usage_table(rows: Sequence[tuple[str, str, dict, float]]) -> str:
    """One line per ``(board, method, usage, read)`` and agent: return, success and length over
    the episodes, the same run's final return as its board reads it (``read``), and every
    option the agent chose, by its share."""
    table = []
    for board, method, usage, read in rows:
        for i, (agent, choices) in enumerate(usage["choices"].items()):
            outcome = (
                [
                    board,
                    f"`{method}`",
                    f"{usage['return_mean']:.1f}",
                    "—" if math.isnan(read) else f"{read:.1f}",
                    f"{usage['success_rate']:.0%}",
                    f"{usage['length_mean']:.1f}",
                ]
                if i == 0
                else [""] * 6
            )
            table.append([*outcome, agent, option_shares(choices)])
    header = [
        "board",
        "method (seed 0)",
        "return",
        "its run, as the board reads it",
        "success",
        "length",
        "agent",
        "its options",
    ]
    return markdown_table(header, table)
