"""Mac-DQN vs async (the paper's Table I) on Tool Delivery: samples to the threshold and peak.

Run (full benchmark, hours on 2 cores)::

    .venv/bin/python bench/macdqn_vs_async.py --seeds 0 1 2 3 4 --total-samples 200000

Each (method, seed) trains into ``<out>/<method>/seed<s>`` (a normal ``train`` run directory),
then writes ``<out>/<method>/seed<s>/result.json``. A rerun skips every run that has its
result, resumes a run that was interrupted (from its checkpoint), and always rewrites the summary
``<out>/summary.md`` from all results found. Both methods get the same budget in low-level ticks.

Curves are compared on the mean episode return (the honest metric), smoothed over a window of
``--window`` iterations with finished episodes: *samples to threshold* is the tick count at the
first iteration whose smoothed return reaches ``--threshold`` (200, the bar used for async);
*peak* is the highest smoothed return.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
from train.config import TrainConfig
from train.run_log import read_metrics
from train.trainer import CHECKPOINT, train

METHODS = ("async", "mac-dqn")


def curve_summary(metrics: Path, threshold: float, window: int) -> dict[str, Any]:
    """Samples to reach ``threshold`` (``None`` if never) and peak of the smoothed return."""
    every = read_metrics(metrics)
    rows = [r for r in every if not math.isnan(float(r["episode_return"]))]
    samples = np.array([int(r["samples"]) for r in rows])
    returns = np.array([float(r["episode_return"]) for r in rows])
    if len(returns) < window:
        return {"samples_to_threshold": None, "peak_return": None, "final_samples": None}

    smooth = np.convolve(returns, np.ones(window) / window, mode="valid")
    at = samples[window - 1 :]
    reached = np.flatnonzero(smooth >= threshold)
    return {
        "samples_to_threshold": int(at[reached[0]]) if reached.size else None,
        "peak_return": float(smooth.max()),
        "peak_samples": int(at[int(smooth.argmax())]),
        "final_samples": int(every[-1]["samples"]),
    }


def run_one(method: str, seed: int, args: argparse.Namespace) -> dict[str, Any]:
    """Train (or resume) one run unless its result exists; return its result."""
    run_dir = Path(args.out) / method / f"seed{seed}"
    result_path = run_dir / "result.json"
    if result_path.exists():
        return json.loads(result_path.read_text())
    resume = (run_dir / CHECKPOINT).exists()
    config = TrainConfig(
        task="tool_delivery",
        method=method,
        seed=seed,
        total_samples=args.total_samples,
        run_dir=str(run_dir),
        progress=not args.quiet,
        video=False,
        torch_threads=args.torch_threads,
    )
    train(config, resume=resume, overwrite=not resume)
    result = {
        "method": method,
        "seed": seed,
        "total_samples": args.total_samples,
        "threshold": args.threshold,
        "window": args.window,
        **curve_summary(run_dir / "metrics.csv", args.threshold, args.window),
    }
    result_path.write_text(json.dumps(result, indent=2) + "\n")
    return result


def _mean_std(values: list[float]) -> str:
    if not values:
        return "—"
    return f"{np.mean(values):,.0f} ± {np.std(values):,.0f}"


def summary(results: list[dict[str, Any]]) -> str:
    lines = [
        "| method | seeds | reached threshold | samples to threshold | peak return |",
        "|---|---|---|---|---|",
    ]
    for method in METHODS:
        mine = [r for r in results if r["method"] == method]
        if not mine:
            continue
        hits = [r["samples_to_threshold"] for r in mine if r["samples_to_threshold"] is not None]
        peaks = [r["peak_return"] for r in mine if r["peak_return"] is not None]
        lines.append(
            f"| {method} | {len(mine)} | {len(hits)}/{len(mine)} | {_mean_std(hits)} "
            f"| {_mean_std(peaks)} |"
        )
    first = results[0]
    lines.append(
        f"\nTool Delivery, {first['total_samples']:,} ticks per run, threshold "
        f"{first['threshold']} mean episode return over a {first['window']}-iteration window; "
        "samples to threshold average the seeds that reached it."
    )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    parser.add_argument("--total-samples", type=int, default=200_000)
    parser.add_argument("--threshold", type=float, default=200.0)
    parser.add_argument("--window", type=int, default=10, help="iterations in the moving mean")
    parser.add_argument("--out", default="runs/bench/macdqn_vs_async")
    parser.add_argument("--torch-threads", type=int, default=1)
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)

    for seed in args.seeds:
        for method in args.methods:
            print(json.dumps(run_one(method, seed, args)), flush=True)
    found = sorted(Path(args.out).glob("*/seed*/result.json"))
    text = summary([json.loads(p.read_text()) for p in found])
    (Path(args.out) / "summary.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
