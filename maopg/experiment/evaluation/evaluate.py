"""Evaluate a policy over N seeded episodes: return, success, length, and the paper's metric.

The honest metric is the mean episode **return** (sum of tick rewards over an episode). The
paper's Tool Delivery numbers are the mean **option-step reward** (the summed reward of one
decision step, averaged over the steps of a batch); it is reported beside the return, in its
own field, and the two must never be compared with each other.

The evaluations during and after training bound each episode at :data:`EVAL_MAX_TICKS` ticks,
as the video is bounded, so a run with ``env.max_ticks=1000000000`` still finishes;
``python -m eval evaluate``, the user's own evaluation, plays every episode to its end.

The evaluation during training (``eval_every``, the curve published results plot) plays
:func:`evaluate` too; :func:`evaluation_due`, :func:`evaluation_seeds` and
:func:`evaluation_row` say when, from which seeds, and what goes in the row.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from maopg.env import DecisionPoint, OptionEnv
from maopg.env.rollout import ReferencePolicy, run_episode
from maopg.experiment.run.directory import EVAL_COLUMNS
from maopg.progress import shows_bar

BEHAVIOUR_VERSION = 1
"""The version of what :func:`evaluate` computes from the episodes it plays (which episodes, how
they are seeded and summarised): raise it when that changes, so cached evaluations
(:mod:`maopg.experiment.studies.cache`) are made again."""

EVAL_MAX_TICKS = 1000
"""Ticks an episode of the evaluation after training plays at most (the trainer passes it as
``max_ticks``): over three times the longest default episode (Water Filling's 300 ticks; Tool
Delivery's 150), so default runs are never cut, while an endless one is, at a cost of minutes,
not days. The same figure as the video's :data:`maopg.env.video.VIDEO_MAX_TICKS`, for the
same reason, but its own constant: an evaluation without frames could afford more."""


@dataclass
class EvalResult:
    """Per-episode outcomes and their summaries."""

    label: str
    task: str
    strategy: str
    seed: int
    returns: list[float]
    lengths: list[int]
    solved: list[bool]
    option_step_rewards: list[float] = field(repr=False)
    """Summed reward of every decision step of every episode."""
    choices: dict[str, dict[str, int]] = field(default_factory=dict, repr=False)
    """Agent → option name → how often the agent chose it, over all episodes: shows a policy
    that is stuck repeating one option, which a return alone does not."""
    cut: list[bool] = field(default_factory=list, repr=False)
    """Per episode: stopped at ``max_ticks`` of :func:`evaluate` while it went on (its return
    and length are then those of its first ``max_ticks`` ticks)."""
    source: dict[str, Any] = field(default_factory=dict, repr=False)
    """What was evaluated — the task and its settings, the policy, the plugins
    (:func:`maopg.experiment.evaluation.provenance.provenance`) — where the caller recorded it."""

    @property
    def summary(self) -> dict[str, Any]:
        returns = np.asarray(self.returns)
        lengths = np.asarray(self.lengths)
        return {
            "label": self.label,
            "task": self.task,
            "strategy": self.strategy,
            "seed": self.seed,
            "episodes": len(self.returns),
            "return_mean": float(returns.mean()),
            "return_std": float(returns.std()),
            "success_rate": float(np.mean(self.solved)),
            "length_mean": float(lengths.mean()),
            "length_std": float(lengths.std()),
            "option_step_reward": float(np.mean(self.option_step_rewards)),
        }

    def to_json(self) -> str:
        episodes = {key: value for key, value in asdict(self).items() if key != "source"}
        record = {**self.summary, "source": self.source, "per_episode": episodes}
        return json.dumps(record, indent=2) + "\n"


def evaluate(
    env: OptionEnv,
    policy: ReferencePolicy,
    episodes: int,
    *,
    seed: int = 0,
    label: str = "",
    progress: bool = False,
    max_ticks: int | None = None,
) -> EvalResult:
    """Play ``episodes`` episodes; episode ``j`` is reset with seed ``seed + j`` (``progress``:
    a bar over the episodes on stderr). With ``max_ticks`` an episode still running at that
    tick is cut there (:func:`maopg.env.rollout.run_episode`; ``cut`` says which)."""
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    agents = env.spec.agents
    choices: list[Counter[str]] = [Counter() for _ in agents]

    def counted(point: DecisionPoint) -> np.ndarray:
        joint = np.asarray(policy(point))
        for i in np.flatnonzero(point.choosing):
            choices[i][agents[i].option_names[joint[i]]] += 1
        return joint

    seeds = tqdm(
        range(seed, seed + episodes),
        desc=f"evaluating {label or env.spec.task}",
        unit="episode",
        disable=not shows_bar(progress),
        leave=False,
        mininterval=0,  # an episode is a coarse step: show each one, however fast it ran
    )
    results = [run_episode(env, counted, seed=j, max_ticks=max_ticks) for j in seeds]
    return EvalResult(
        label=label,
        task=env.spec.task,
        strategy=env.strategy.value,
        seed=seed,
        returns=[r.ret for r in results],
        lengths=[r.ticks for r in results],
        solved=[r.solved for r in results],
        option_step_rewards=[x for r in results for x in r.rewards],
        choices={a.name: dict(c.most_common()) for a, c in zip(agents, choices, strict=True)},
        cut=[r.cut for r in results],
    )


def option_shares(counts: dict[str, int], top: int | None = None) -> str:
    """``"180 choices — GoToTR 56%, GetTool 22%, ..."``: an agent's options by their share of
    its choices, most chosen first (ties in name order; under half a per cent: ``<1%``), the
    ``top`` most chosen and the rest as ``other`` (``None``: every option chosen)."""
    total = sum(counts.values())
    if not total:
        return "no choice"

    def share(count: int) -> str:
        return "<1%" if count / total < 0.005 else f"{count / total:.0%}"

    ranked = sorted(((n, c) for n, c in counts.items() if c), key=lambda item: (-item[1], item[0]))
    shown = ranked if top is None else ranked[:top]
    parts = [f"{name} {share(count)}" for name, count in shown]
    rest = sum(count for _, count in ranked[len(shown) :])
    if rest:
        parts.append(f"other {share(rest)}")
    return f"{total} choices — " + ", ".join(parts)


def choices_lines(result: EvalResult, top: int = 4) -> list[str]:
    """Each agent's most chosen options with their share of its choices."""
    return [f"{agent}: {option_shares(counts, top)}" for agent, counts in result.choices.items()]


def results_table(summaries: list[dict[str, Any]]) -> str:
    """Markdown table, one row per evaluated policy (:attr:`EvalResult.summary` dicts)."""
    header = (
        "| policy | task | strategy | episodes | return | success | length "
        "| option-step reward (paper's metric) |\n|---|---|---|---|---|---|---|---|\n"
    )
    rows = []
    for s in summaries:
        rows.append(
            f"| {s['label']} | {s['task']} | {s['strategy']} | {s['episodes']} "
            f"| {s['return_mean']:.1f} ± {s['return_std']:.1f} | {s['success_rate']:.0%} "
            f"| {s['length_mean']:.1f} ± {s['length_std']:.1f} | {s['option_step_reward']:.2f} |"
        )
    return header + "\n".join(rows) + "\n"


def write_result(result: EvalResult, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(result.to_json())
    return path


# ---------------------------------------------------------------------- during training
NO_EVALUATION = dict.fromkeys(EVAL_COLUMNS, math.nan)
"""The evaluation columns of a row without an evaluation."""

EVAL_STREAM = 0xE7A1
"""The spawn key that sets the evaluation's seeds apart from every stream of the training
(:func:`maopg.env.vector.episode_seed` hashes ``[run seed, env, episode]`` without one)."""


def evaluation_due(before: int, after: int, every: int) -> int | None:
    """The index ``k`` of the evaluation due after an iteration that took the run from
    ``before`` to ``after`` samples: it reached ``k * every``, the largest multiple it passed
    (one evaluation, however many it passed); ``None`` when it reached none, or ``every`` is 0.
    A function of the sample counts alone, so a resumed run evaluates where an uninterrupted
    one does."""
    if every < 1 or after // every == before // every:
        return None
    return after // every


def evaluation_seeds(run_seed: int, index: int) -> tuple[int, int]:
    """``(episode seed, acting seed)`` of evaluation ``index`` of run ``run_seed``: its episode
    ``j`` is reset with ``episode seed + j`` and its sampled options come from a generator
    seeded with the acting seed. Derived from numpy's ``SeedSequence`` with a spawn key of
    their own, they draw from no stream of the training, whose curve therefore does not depend
    on whether it evaluates; each evaluation plays other episodes than the last."""
    words = np.random.SeedSequence(run_seed, spawn_key=(EVAL_STREAM, index)).generate_state(2)
    return int(words[0]) % 2**31, int(words[1])  # 31 bits: ``seed + j`` stays a 32-bit seed


def evaluation_row(result: EvalResult) -> dict[str, float]:
    """The :data:`~maopg.experiment.run.directory.EVAL_COLUMNS` of an evaluation's ``result``."""
    summary = result.summary
    keys = ("return_mean", "return_std", "success_rate", "length_mean")
    return {column: summary[key] for column, key in zip(EVAL_COLUMNS, keys, strict=True)}
