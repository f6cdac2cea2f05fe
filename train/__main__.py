"""Command line: ``python -m train --task tool_delivery --method async --seed 0 [key=value ...]``.

Named flags cover what one changes per run; any :class:`~train.config.TrainConfig` field can be
overridden as ``key=value`` (``epochs=5 num_envs=8``), Mac-DQN's as ``dqn.key=value`` and task
settings as ``env.key=value``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import maopg  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)
from maopg.tasks import task_names
from train.config import METHODS, TrainConfig, merge, parse_overrides
from train.run_log import CONFIG


def parse_args(argv: list[str] | None = None) -> tuple[TrainConfig, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        prog="python -m train",
        description="Train an option-based multi-agent policy (MAPPO, or the Mac-DQN baseline).",
        epilog="Extra arguments key=value override any config field (e.g. epochs=5, "
        "discount=option, num_workers=2, video=false), as dqn.key=value a Mac-DQN "
        "hyper-parameter (dqn.lr=1e-3) or, as env.key=value, a task setting.",
    )
    parser.add_argument("--task", choices=task_names(), default=None)
    parser.add_argument("--method", choices=sorted(METHODS), default=None)
    parser.add_argument("--seed", type=int, default=None)
    parser.add_argument("--total-samples", type=int, default=None, help="low-level ticks")
    parser.add_argument("--run-dir", default=None, help="default runs/<task>/<method>/seed<seed>")
    parser.add_argument("--resume", action="store_true", help="continue the run in --run-dir")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing run")
    parser.add_argument(
        "--images", action=argparse.BooleanOptionalAction, default=None, help="RGB observations"
    )
    parser.add_argument("overrides", nargs="*", metavar="key=value")
    args = parser.parse_intermixed_args(argv)

    try:
        values = parse_overrides(args.overrides)
    except ValueError as err:
        parser.error(str(err))
    named = {
        "task": args.task,
        "method": args.method,
        "seed": args.seed,
        "total_samples": args.total_samples,
        "run_dir": args.run_dir,
        "images": args.images,
    }
    values.update({k: v for k, v in named.items() if v is not None})
    config = TrainConfig.from_dict(merge(TrainConfig().to_dict(), values))
    if args.resume:
        # A resumed run starts from its saved config; flags given now must agree with it.
        saved = Path(config.resolved().run_dir) / CONFIG  # type: ignore[arg-type]
        if saved.exists():
            config = TrainConfig.from_dict(merge(TrainConfig.load(saved).to_dict(), values))
    return config, args


def main(argv: list[str] | None = None) -> int:
    config, args = parse_args(argv)
    from train.trainer import train

    run_dir = train(config, resume=args.resume, overwrite=args.overwrite)
    print(f"run directory: {run_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
