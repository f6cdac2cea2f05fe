"""Cost of one decision point's policy step as the team grows: product categorical vs chain rule.

Run: ``.venv/bin/python bench/perf/policy_scaling.py [--agents 2,3,4,6,8,12,16] [--options 6,13]``.
Prints a Markdown table and the conditions (machine, versions, load).

For each team of ``N`` agents with ``K`` options each, one training step of the policy on a
minibatch of ``--batch`` decision points: encoder forward, the conditional, a sample, the
log-probability and entropy of the sampled joint, and the backward pass — what MAPPO does per
point, acting and updating. The product categorical (:class:`CentralizedPolicy`, the ``async``
policy) and the autoregressive one (:class:`AutoregressivePolicy`, ``async-ar``) see the same
state observations (12 floats per agent), the same conditions (a random half of the agents
choose, at least one) and the same hidden width (the autoregressive policy adds a local
encoder per agent).

Each cell runs in a fresh process, so its peak memory is that process's high-water resident
size above what it held once torch was imported and the inputs were made. A product categorical
whose head (``ΠK`` outputs) would not fit in half of this machine's memory is not built: the
table prints its estimated need (:mod:`maopg.policy.joint_size`) instead.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time

OBS_PER_AGENT = 12


def _spec(agents: int, options: int):
    from maopg.env.contract import AgentSpec, EnvSpec, Strategy

    names = tuple(f"o{j}" for j in range(options))
    team = tuple(AgentSpec(f"r{i}", "r", names, OBS_PER_AGENT) for i in range(agents))
    return EnvSpec("bench", Strategy.CONTINUE, team, None, 1.0, 150, 0.99)


def measure(policy: str, agents: int, options: int, batch: int, repeats: int) -> dict:
    """Seconds per decision point (median of ``repeats`` steps) and peak extra memory (MiB)."""
    import torch

    from maopg.learner.mappo import PPOConfig, autoregressive_policy, centralized_policy
    from maopg.policy import ObsBatch

    torch.manual_seed(0)
    torch.set_num_threads(1)
    spec = _spec(agents, options)
    generator = torch.Generator().manual_seed(0)
    obs = ObsBatch(torch.randn(batch, agents * OBS_PER_AGENT), None)
    choosing = torch.rand(batch, agents, generator=generator) < 0.5
    choosing[:, 0] |= ~choosing.any(dim=1)
    running = torch.randint(options, (batch, agents), generator=generator)
    available = torch.ones(batch, agents * options, dtype=torch.bool)
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    build = {"product": centralized_policy, "autoregressive": autoregressive_policy}[policy]
    network = build(spec, hidden=128, layers=2, config=PPOConfig())
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        dist = network.distribution(obs, choosing, running, available)
        joint = dist.sample(generator)
        loss = -(dist.log_prob(joint).mean() + 0.01 * dist.entropy().mean())
        loss.backward()
        network.zero_grad(set_to_none=True)
        times.append(time.perf_counter() - start)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base  # KiB on Linux
    times.sort()
    return {"seconds": times[len(times) // 2] / batch, "mib": peak / 1024.0}


def _cell(policy: str, agents: int, options: int, batch: int, repeats: int) -> dict:
    """:func:`measure` in a fresh interpreter, or the product head's estimated need."""
    if policy == "product":
        from maopg.policy.joint_size import joint_head_bytes, machine_memory

        need = joint_head_bytes((options,) * agents, hidden=128, copies=4, rows=3 * batch)
        if need > machine_memory() // 2:
            return {"need_gib": need / 2.0**30}
    code = (
        "import json, sys; sys.path.insert(0, 'bench'); import policy_scaling as p; "
        f"print(json.dumps(p.measure({policy!r}, {agents}, {options}, {batch}, {repeats})))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def _fmt(cell: dict) -> tuple[str, str]:
    if "need_gib" in cell:
        return "does not fit", f"≥ {cell['need_gib']:,.0f} GiB (est.)"
    return f"{cell['seconds'] * 1e3:.3f}", f"{cell['mib']:.0f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--agents", default="2,3,4,6,8,12,16")
    parser.add_argument("--options", default="6,13")
    parser.add_argument("--batch", type=int, default=64, help="decision points per step")
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()
    teams = [int(n) for n in args.agents.split(",")]

    import torch

    from maopg.experiment.run.sysinfo import markdown

    torch.set_num_threads(1)  # what every cell runs with, so the conditions print it
    print("### Policy cost against team size: product categorical vs autoregressive")
    print("(`bench/perf/policy_scaling.py`)\n")
    print(markdown(gl=False))
    print(
        f"\nOne policy step (forward, sample, log-prob + entropy, backward) on {args.batch} "
        f"decision points, state observations, hidden 128 × 2 layers, 1 torch thread; "
        f"median of {args.repeats}; memory = peak RSS growth of a fresh process.\n"
    )
    print(
        "| K | N | ΠK | product ms/point | product MiB | AR ms/point | AR MiB | AR ms/point ÷ N |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for options in (int(k) for k in args.options.split(",")):
        ar_times = {}
        for agents in teams:
            product = _cell("product", agents, options, args.batch, args.repeats)
            ar = _cell("autoregressive", agents, options, args.batch, args.repeats)
            ar_times[agents] = ar["seconds"]
            p_time, p_mem = _fmt(product)
            a_time, a_mem = _fmt(ar)
            per_agent = ar["seconds"] * 1e3 / agents
            print(
                f"| {options} | {agents} | {options**agents:,} | {p_time} | {p_mem} | {a_time} "
                f"| {a_mem} | {per_agent:.4f} |",
                flush=True,
            )
        xs = [math.log(n) for n in ar_times]
        ys = [math.log(t) for t in ar_times.values()]
        mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
        slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum(
            (x - mx) ** 2 for x in xs
        )
        print(f"| {options} | fit | | | | AR time ∝ N^{slope:.2f} (least squares, log-log) | | |")
    print(f"\nload average (1 min) at the end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
