"""Wall-clock of training on Water Filling from RGB: 200K samples of `async` in ≤ 15 min?

Run: ``.venv/bin/python bench/perf/train_speed_wf.py [--precision bf16] [--workers 4] [--seed 1]
[--run-dir DIR]``. Target (issue 16): 200K samples of `async` (64 px cameras on both robots,
command-line defaults but ``precision`` and the backend) in ≤ 15 minutes on 2 cores, with a
learning curve within the noise of the committed grid's (results/runs/water_filling/async, seeds
0-2, trained by the code before the image bank and the threaded backend: 26.0, 35.2 and 26.0
min, in ``fp32``). ``--precision bf16`` runs the CNNs in bfloat16 (the ``precision`` setting),
which is where most of an update's time goes; the conditions list whether this CPU has bf16
instructions. ``--workers N`` steps the environments in N spawned processes (N = 4, one per
environment, is Water Filling's default backend); without it they step on threads, the default
before it. The backend changes no number of the run, only its wall-clock. ``--seed`` (default 0)
trains another seed: one seed's final return outside the grid's range cannot tell the code's
effect from the seed's noise.

A short run cannot give the verdict: cameras render and the CNN runs at every decision point,
and the policy makes more decisions as it learns (about 350-400 per 1,000 ticks untrained,
550-830 trained), so the first iterations are the fastest. So this trains the whole 200K run,
timed by its own ``metrics.csv``, into a run directory that a rerun resumes (and a finished one
only reports): it spans sessions if it must. The machine's load is sampled every 10 s while it
trains and printed with the figure. The grid's runs were timed on other machines and loads;
the like-for-like old-vs-new rate on this machine is ``bench/perf/compare_checkouts.py --sections
train`` (its ``wf-rgb`` row).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import threading
from pathlib import Path

import torch

from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import read_done
from maopg.experiment.run.sysinfo import markdown
from maopg.experiment.studies.runs import RunData, final, load_run, peak
from maopg.experiment.training.trainer import train
from maopg.policy import PRECISIONS

TARGET_SAMPLES = 200_000
TARGET_MINUTES = 15.0
LOADS = "bench_loads.json"
"""Load averages sampled while the run trained (kept in the run directory, over sessions)."""


def _sample_loads(path: Path, stop: threading.Event) -> None:
    loads = json.loads(path.read_text()) if path.exists() else []
    while not stop.wait(10.0):
        loads.append(os.getloadavg()[0])
        path.write_text(json.dumps(loads))


def _decisions_per_1k(run: RunData, start: int, stop: int | None) -> float:
    ticks = run.samples[stop - 1 if stop else -1] - (run.samples[start - 1] if start else 0.0)
    return float(1000 * run.metrics["option_steps"][start:stop].sum() / ticks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--precision",
        choices=PRECISIONS,
        default="fp32",
        help="what the CNNs compute in (the precision setting; default %(default)s)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=0,
        help="spawned worker processes (backend=processes); default 0: backend=threads",
    )
    parser.add_argument(
        "--run-dir",
        type=Path,
        help="default runs/bench/train_speed_wf[_bf16][_processesN], by the options above",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="the run's seed (default %(default)s); the other seeds say whether a return outside "
        "the grid's range is this seed's noise or the code's",
    )
    parser.add_argument("--grid", type=Path, default=Path("results/runs/water_filling/async"))
    args = parser.parse_args()
    if args.run_dir is None:
        suffix = "" if args.precision == "fp32" else f"_{args.precision}"
        suffix += f"_processes{args.workers}" if args.workers else ""
        suffix += f"_seed{args.seed}" if args.seed else ""
        args.run_dir = Path(f"runs/bench/train_speed_wf{suffix}")
    torch.set_num_threads(TrainConfig.torch_threads)  # what train() sets: the conditions say so
    conditions = markdown()
    config = TrainConfig(
        task="water_filling",
        method="async",
        seed=args.seed,
        total_samples=TARGET_SAMPLES,
        run_dir=str(args.run_dir),
        progress=False,
        video=False,
        precision=args.precision,
        backend="processes" if args.workers else "threads",
        num_workers=args.workers,
    )
    if read_done(args.run_dir) is None:
        stop = threading.Event()
        sampler = threading.Thread(target=_sample_loads, args=(args.run_dir / LOADS, stop))
        args.run_dir.mkdir(parents=True, exist_ok=True)
        sampler.start()
        try:
            train(config, resume=(args.run_dir / "config.json").exists())
        finally:
            stop.set()
            sampler.join()
    run = load_run(args.run_dir)
    loads = json.loads((args.run_dir / LOADS).read_text())
    minutes = run.metrics["wall_time"][-1] / 60

    print("### Training wall-clock, Water Filling RGB (`bench/perf/train_speed_wf.py`)\n")
    print(conditions)
    print(
        f"- load average (1 min) while training, sampled every 10 s: median "
        f"{statistics.median(loads):.2f} (min {min(loads):.2f}, max {max(loads):.2f})"
    )
    backend = f"processes num_workers={args.workers}" if args.workers else "threads"
    print(
        f"- this run: seed {args.seed}, `precision={args.precision}`, {backend} (`{args.run_dir}`)"
    )
    print(f"- target: `async`, {TARGET_SAMPLES:,} samples in ≤ {TARGET_MINUTES:.0f} min\n")
    print(
        "| run | code | samples | wall-clock | samples/s | ms per decision point | decisions per "
        "1K ticks, first → last 10% | final 10% return | peak return |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    grid = [load_run(d) for d in sorted(args.grid.glob("seed*"))]
    for label, each in [("this run", run), *((f"grid {g.path.name}", g) for g in grid)]:
        wall = each.metrics["wall_time"][-1] / 60
        tenth = max(1, len(each.samples) // 10)
        first = _decisions_per_1k(each, 0, tenth)
        last = _decisions_per_1k(each, len(each.samples) - tenth, None)
        per_decision = 1000 * wall * 60 / each.metrics["option_steps"].sum()  # ms
        code = "this tree" if each is run else "committed grid"
        print(
            f"| {label} | {code} | {each.samples[-1]:,.0f} | {wall:.1f} min | "
            f"{each.samples[-1] / (wall * 60):.0f} | {per_decision:.1f} | "
            f"{first:.0f} → {last:.0f} | "
            f"{final(each):,.0f} | {peak(each, window=10):,.0f} |"
        )
    finals = [final(g) for g in grid]
    inside = min(finals) <= final(run) <= max(finals) if finals else False
    print(
        f"\nTarget {'met' if minutes <= TARGET_MINUTES else '**not met**'}: {minutes:.1f} min. "
        f"Final-10% return {final(run):,.0f} against the grid's "
        f"{statistics.mean(finals):,.0f} ± {statistics.pstdev(finals):,.0f} "
        f"(seeds' range {min(finals):,.0f} to {max(finals):,.0f}): "
        f"{'inside' if inside else '**outside**'} the grid's range."
        if finals
        else f"\nTarget {'met' if minutes <= TARGET_MINUTES else '**not met**'}: {minutes:.1f} min."
    )


if __name__ == "__main__":
    main()
