"""Command line: ``python -m train --task tool_delivery --method async --seed 0 [key=value ...]``
(``maopg-train`` once installed).

Named flags cover what one changes per run; any :class:`~maopg.experiment.config.TrainConfig`
field can be overridden as ``key=value`` (``num_envs=8``), the method's hyper-parameters as
``SECTION.key=value`` (``ppo.epochs=5``, ``dqn.lr=1e-3``) and task settings as
``env.key=value``. Tasks and methods are the registries' (``maopg.tasks``,
``maopg.experiment.methods``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import maopg  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)
from maopg.experiment.config import TrainConfig, merge, parse_overrides
from maopg.experiment.methods import method_names
from maopg.experiment.run_dir import CONFIG
from maopg.tasks import task_names


def parse_args(argv: list[str] | None = None) -> tuple[TrainConfig, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        prog="python -m train",
        description="Train an option-based multi-agent policy (MAPPO, or the Mac-DQN baseline).",
        epilog="Extra arguments key=value override any config field (e.g. num_envs=8, "
        "num_workers=2, video=false), SECTION.key=value a hyper-parameter of the method's "
        "learner (ppo.epochs=5, dqn.lr=1e-3) and env.key=value a task setting.",
    )
    parser.add_argument("--task", choices=task_names(), default=None)
    parser.add_argument("--method", choices=sorted(method_names()), default=None)
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

    named = {
        "task": args.task,
        "method": args.method,
        "seed": args.seed,
        "total_samples": args.total_samples,
        "run_dir": args.run_dir,
        "images": args.images,
    }
    named = {k: v for k, v in named.items() if v is not None}
    for item in args.overrides:  # method=NAME works like --method: it picks the section
        key, _, value = item.partition("=")
        if key == "method" and "method" not in named:
            named["method"] = value
    try:
        base = TrainConfig(method=named.get("method", TrainConfig.method)).to_dict()
        if args.resume:
            # A resumed run starts from its saved config; flags given now must agree with it.
            probe = TrainConfig.from_dict(merge(base, named)).resolved()
            saved = Path(probe.run_dir) / CONFIG  # type: ignore[arg-type]
            if saved.exists():
                base = TrainConfig.load(saved).to_dict()
        values = parse_overrides(args.overrides, named.get("method", base["method"]))
        values.update(named)
        config = TrainConfig.from_dict(merge(base, values))
    except ValueError as err:
        parser.error(str(err))
    return config, args


def main(argv: list[str] | None = None) -> int:
    config, args = parse_args(argv)
    from maopg.experiment.trainer import train

    run_dir = train(config, resume=args.resume, overwrite=args.overwrite)
    print(f"run directory: {run_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
