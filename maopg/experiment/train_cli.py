"""Command line: ``python -m train --task tool_delivery --method async --seed 0 [key=value ...]``
(``maopg-train`` once installed).

Named flags cover what one changes per run; any :class:`~maopg.experiment.config.TrainConfig`
field can be overridden as ``key=value`` (``num_envs=8``), the method's hyper-parameters as
``SECTION.key=value`` (``ppo.epochs=5``, ``dqn.lr=1e-3``) and task settings as
``env.key=value``. Tasks and methods are the registries' (``maopg.tasks``,
``maopg.experiment.methods``), extended by plugins (``--import MODULE``), which the run records
so that ``--resume`` and evaluation import them again.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import maopg  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)
from maopg.experiment.command_line import add_common_options, run_command
from maopg.experiment.config import TrainConfig, merge, parse_overrides
from maopg.experiment.methods import method_names
from maopg.experiment.run_dir import CONFIG
from maopg.plugins import load_plugins
from maopg.tasks import task_names

PROG = "python -m train"


def build_parser() -> argparse.ArgumentParser:
    """The parser, its choices from the registries as they are now (plugins loaded)."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Train an option-based multi-agent policy (MAPPO, or the Mac-DQN baseline).",
        epilog="Extra arguments key=value override any config field (e.g. num_envs=8, "
        "num_workers=2, video=false, plot=false, device=cuda), SECTION.key=value a "
        "hyper-parameter of the method's learner (ppo.epochs=5, dqn.lr=1e-3) and env.key=value "
        "a task setting.",
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
    add_common_options(parser)
    parser.add_argument("overrides", nargs="*", metavar="key=value")
    return parser


def parse_args(
    argv: Sequence[str] | None = None, plugins: Sequence[str] = ()
) -> tuple[TrainConfig, argparse.Namespace]:
    """The run's config from ``argv`` (without ``--import``: ``plugins`` are the modules that
    were imported for it)."""
    parser = build_parser()
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
            # A resumed run starts from its saved config (and its plugins, imported before the
            # config is read: its task or method may be theirs); flags must agree with it.
            probe = TrainConfig.from_dict(merge(base, named)).resolved()
            saved = Path(probe.run_dir) / CONFIG  # type: ignore[arg-type]
            if saved.exists():
                load_plugins(_saved_plugins(saved))
                base = TrainConfig.load(saved).to_dict()
        values = parse_overrides(args.overrides, named.get("method", base["method"]))
        values.update(named)
        values["plugins"] = list(dict.fromkeys([*base.get("plugins", []), *plugins]))
        config = TrainConfig.from_dict(merge(base, values))
    except ValueError as err:
        parser.error(str(err))
    return config, args


def _saved_plugins(path: Path) -> list[str]:
    try:
        return list(json.loads(path.read_text()).get("plugins", []))
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is not valid JSON: {err}") from None


def _saved_run_plugins(argv: Sequence[str]) -> list[str]:
    """The plugins of the run that ``--resume --run-dir DIR`` continues, imported before the
    parser is built: its ``--task`` / ``--method`` may be theirs."""
    early = argparse.ArgumentParser(add_help=False)
    early.add_argument("--resume", action="store_true")
    early.add_argument("--run-dir")
    known, _ = early.parse_known_args(argv)
    saved = Path(known.run_dir) / CONFIG if known.resume and known.run_dir else None
    return _saved_plugins(saved) if saved is not None and saved.exists() else []


def _train(argv: list[str], plugins: list[str]) -> int:
    plugins = [*plugins, *load_plugins(_saved_run_plugins(argv))]
    config, args = parse_args(argv, list(dict.fromkeys(plugins)))
    from maopg.experiment.trainer import train

    run_dir = train(config, resume=args.resume, overwrite=args.overwrite)
    print(f"run directory: {run_dir}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_command(PROG, argv, _train)


if __name__ == "__main__":
    sys.exit(main())
