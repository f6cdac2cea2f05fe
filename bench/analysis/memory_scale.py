"""What a recurrent policy's GRU reads and returns: the scale of its inputs, how saturated its
gates are, and the scale of what its head reads, beside a feed-forward policy's head input.

Run: ``.venv/bin/python bench/analysis/memory_scale.py [CHECKPOINT ...] [--episodes 1]``
(default: seed 0 of feed-forward ``async`` and of recurrent ``async``: without option history
or normalisation (``results/memory/unnormalised``), with the option history only (a pilot),
and with both (the ``memory`` study's runs)). The two middle ones are in the history, not the tree:
``git checkout 3d01192 -- results/memory/unnormalised results/memory/pilots`` restores them.

Our encoders end in a ReLU with no normalisation, so their features can be large. A GRU cell's
gates are sigmoids and a tanh of affine maps of its input: fed large inputs they sit near 0 or 1
(or ±1), where their gradient vanishes and a training step barely moves them, and the output,
bounded by the tanh, is far smaller than the features a feed-forward head reads; so the head's
logits, and the policy, move less per update. rMAPPO layer-normalises what its GRU reads and
returns (``ppo.memory_norm``). This plays each checkpoint's sampled policy (as in training) and
prints, over every decision point and memory slot: the mean norm of the encoder's features, of
what the cell reads (after the LayerNorm, where there is one), of what the head reads (the
cell's output, normalised or not; a feed-forward policy's features), and the share of the
cell's gate values that are saturated (reset and update gates outside [0.02, 0.98], candidate
outside [−0.98, 0.98]).
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

DEFAULT = [
    Path("results/runs/water_filling/async/seed0/final.pt"),
    Path("results/memory/unnormalised/water_filling/async-rnn/seed0/final.pt"),
    Path("results/memory/pilots/async-rnn-opthist-s0/final.pt"),
    Path("results/memory/runs/water_filling/async-rnn/seed0/final.pt"),
]
EDGE = 0.02
"""A gate value within this of its bound counts as saturated."""


def gates(cell: torch.nn.GRUCell, x: torch.Tensor, h: torch.Tensor) -> torch.Tensor:
    """The reset, update and candidate values of ``cell`` at input ``x`` and state ``h``
    (torch's GRUCell equations), ``[3, B, H]``."""
    gi = x @ cell.weight_ih.T + cell.bias_ih
    gh = h @ cell.weight_hh.T + cell.bias_hh
    i_r, i_z, i_n = gi.chunk(3, dim=-1)
    h_r, h_z, h_n = gh.chunk(3, dim=-1)
    reset, update = torch.sigmoid(i_r + h_r), torch.sigmoid(i_z + h_z)
    return torch.stack([reset, update, torch.tanh(i_n + reset * h_n)])


def measure(checkpoint: Path, episodes: int) -> dict[str, float]:
    """Mean norms and gate saturation over ``episodes`` sampled episodes (module doc)."""
    trained = load_trained(checkpoint)
    policy, env = trained.policy.eval(), trained.make_env(0)
    memory = getattr(policy, "memory", None)
    generator = torch.Generator().manual_seed(0)
    seen: dict[str, list[float]] = {"features": [], "cell reads": [], "head reads": []}
    saturated: list[float] = []
    try:
        for episode in range(episodes):
            point, state = env.reset(seed=episode), policy.initial_state(1)
            while not point.done:
                obs = ObsBatch.from_decision_points([point])
                conditions = stack_conditions([point])
                starts = episode_starts([point])
                with torch.no_grad():
                    features = policy.encode(obs)
                    seen["features"] += [float(f.norm()) for f in features]
                    if memory is None:
                        seen["head reads"] += [float(f.norm()) for f in features]
                        dist = policy.distribution(obs, *conditions)
                    else:
                        carried = state * (~starts).float().view(-1, 1, 1)
                        history = memory.history(conditions[0], conditions[1])
                        for slot, cell in enumerate(memory.cells):
                            x = features[slot]
                            if memory.norms is not None:
                                x = memory.norms[slot][0](x)
                            seen["cell reads"].append(float(x.norm()))
                            if history is not None:
                                x = torch.cat([x, history], dim=-1)
                            g = gates(cell, x, carried[:, slot])
                            edge = torch.stack([g[0], g[1], (g[2] + 1) / 2])
                            saturated.append(
                                float(((edge < EDGE) | (edge > 1 - EDGE)).float().mean())
                            )
                        dist, state = policy.step(obs, *conditions, state, starts)
                        outputs = (
                            state
                            if memory.norms is None
                            else torch.stack(
                                [memory.norms[s][1](state[:, s]) for s in range(memory.slots)],
                                dim=1,
                            )
                        )
                        seen["head reads"] += [float(o.norm()) for o in outputs[0]]
                    joint = dist.sample(generator)[0].numpy()
                point = env.step(joint)
    finally:
        env.close()
    figures = {
        key: float(np.mean(values)) if values else float("nan") for key, values in seen.items()
    }
    figures["saturated"] = float(np.mean(saturated)) if saturated else float("nan")
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoints", nargs="*", type=Path, default=DEFAULT)
    parser.add_argument("--episodes", type=int, default=1, help="per checkpoint (%(default)s)")
    args = parser.parse_args()
    missing = [str(path) for path in args.checkpoints if not path.exists()]
    if missing:
        parser.error(f"no such checkpoint {missing[0]} (the module docstring says how to restore)")
    torch.set_num_threads(1)
    title = "What a recurrent policy's GRU reads and returns"
    print(f"### {title} (`bench/analysis/memory_scale.py`)\n")
    print(markdown())
    print(
        f"- each checkpoint's policy, sampled, {args.episodes} episodes (reset seeds 0, 1, ...)\n"
    )
    print("| checkpoint | features | cell reads | head reads | saturated gate values |")
    print("|---|---|---|---|---|")
    for checkpoint in args.checkpoints:
        f = measure(checkpoint, args.episodes)
        cell = "—" if np.isnan(f["cell reads"]) else f"{f['cell reads']:.1f}"
        gate = "—" if np.isnan(f["saturated"]) else f"{f['saturated']:.0%}"
        print(
            f"| `{checkpoint.parent}` "
            f"| {f['features']:.1f} | {cell} | {f['head reads']:.1f} | {gate} |"
        )


if __name__ == "__main__":
    main()
