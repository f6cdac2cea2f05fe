"""How sure a trained policy is of its own choices: why a greedy policy loops where the sampled
one does not.

Run: ``.venv/bin/python bench/analysis/policy_modes.py [CHECKPOINT ...] [--episodes 2] [--sample]``
(default: seed 0 of each Water Filling method of the grid, of the ``memory`` study and of its
unnormalised runs).

Greedy evaluation takes the mode of every choosing agent's option distribution. That is a
faithful summary of a policy only where the policy is sure; where it spreads its probability,
the sampled policy mixes options and the greedy one always takes the same. A one-tick option
such as ``Fill(j)`` makes that visible: where the mode is the option the agent has just run, the
greedy agent runs it again at the next point, which looks the same, and again, for the rest of
the episode, while the sampled agent leaves as soon as it draws something else.

This plays each checkpoint's greedy policy (its mode), or with ``--sample`` its sampled one (as
in training), and at each choosing agent's decision records its marginal distribution (the
centralized policy's joint slice summed over the other choosing agents; a per-agent policy's own
factor): the mode's probability, whether the mode is the option the agent has just run
(``running``: so greedy would repeat it), and whether the option chosen repeats it. It prints
them per agent. A greedy loop reads as ``chosen = last option`` near 100% with the mode's
probability there well below 1: a point the sampled policy would leave.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from maopg.experiment.evaluation.loading import load_trained
from maopg.experiment.run.sysinfo import markdown
from maopg.policy import ObsBatch
from maopg.policy.actors import episode_starts
from maopg.policy.batch import stack_conditions
from maopg.policy.conditional import ConditionalJoint, FactoredConditional

DEFAULT = [
    Path(f"results/{root}/water_filling/{method}/seed0/final.pt")
    for root, methods in (
        ("runs", ("async", "sync-wait", "partial")),
        ("memory/unnormalised", ("async-rnn", "sync-wait-rnn", "partial-rnn")),
        ("memory/runs", ("async-rnn", "sync-wait-rnn", "partial-rnn")),
    )
    for method in methods
]


def marginals(dist) -> list[torch.Tensor]:
    """Each agent's ``[K_i]`` option probabilities at a one-row point (module doc)."""
    if isinstance(dist, FactoredConditional):
        return [lp[0].exp() for lp in dist.agent_log_probs]
    if isinstance(dist, ConditionalJoint):
        counts = dist.option_counts
        joint = dist.probs[0].view(counts)
        return [
            joint.sum(dim=[d for d in range(len(counts)) if d != i]) for i in range(len(counts))
        ]
    raise TypeError(f"{type(dist).__name__}: this script reads product and per-agent policies")


def choices(
    checkpoint: Path, episodes: int, greedy: bool
) -> dict[str, list[tuple[float, bool, bool]]]:
    """Per agent, at each of its decisions: ``(P(mode), mode is its last option, the chosen
    option is its last option)``, over ``episodes`` episodes (reset seeds 0, 1, ...), sampled
    or ``greedy``."""
    trained = load_trained(checkpoint)
    policy, env = trained.policy.eval(), trained.make_env(0)
    generator = torch.Generator().manual_seed(0)
    seen: dict[str, list[tuple[float, bool, bool]]] = {a: [] for a in trained.spec.agent_names}
    try:
        for episode in range(episodes):
            point, state = env.reset(seed=episode), policy.initial_state(1)
            while not point.done:
                obs = ObsBatch.from_decision_points([point])
                with torch.no_grad():
                    dist, state = policy.step(
                        obs, *stack_conditions([point]), state, episode_starts([point])
                    )
                    joint = (dist.mode() if greedy else dist.sample(generator))[0].numpy()
                probs = marginals(dist)
                for i, agent in enumerate(trained.spec.agent_names):
                    if point.choosing[i]:
                        p = probs[i]
                        last = int(point.running[i])
                        seen[agent].append(
                            (float(p.max()), int(p.argmax()) == last, int(joint[i]) == last)
                        )
                point = env.step(joint)
    finally:
        env.close()
    return seen


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoints", nargs="*", type=Path, default=DEFAULT)
    parser.add_argument("--episodes", type=int, default=2, help="per checkpoint (%(default)s)")
    parser.add_argument("--sample", action="store_true", help="sample, not the mode")
    args = parser.parse_args()
    torch.set_num_threads(1)
    print("### How sure trained policies are of their choices (`bench/analysis/policy_modes.py`)\n")
    print(markdown())
    acting = "sampled" if args.sample else "greedy (the mode)"
    print(
        f"- each checkpoint's policy, {acting}, {args.episodes} episodes (reset seeds 0, 1, ...)\n"
    )
    print(
        "| checkpoint | agent | decisions | mean P(mode) | P(mode) < 0.6 "
        "| mode = last option | its P(mode) there | chosen = last option |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for checkpoint in args.checkpoints:
        for agent, rows in choices(checkpoint, args.episodes, not args.sample).items():
            if not rows:
                continue
            sure, mode_repeats, sample_repeats = (np.array(c) for c in zip(*rows, strict=True))
            repeat_sure = f"{sure[mode_repeats].mean():.2f}" if mode_repeats.any() else "—"
            print(
                f"| `{checkpoint.parent}` | {agent} "
                f"| {len(rows)} | {sure.mean():.2f} | {(sure < 0.6).mean():.0%} "
                f"| {mode_repeats.mean():.0%} | {repeat_sure} | {sample_repeats.mean():.0%} |"
            )


if __name__ == "__main__":
    main()
