"""Command line: ``python -m train --task tool_delivery --method async --seed 0 [key=value ...]``
(``maopg-train`` once installed).

Named flags cover what one changes per run; any :class:`~maopg.experiment.run.config.TrainConfig`
field can be overridden as ``key=value`` (``num_envs=8``), the method's hyper-parameters as
``SECTION.key=value`` (``ppo.epochs=5``, ``dqn.lr=1e-3``) and task settings as
``env.key=value``, over the settings of a ``--config run.yaml`` (or ``.json``) file; a
``key=value`` that repeats a flag (``seed=2`` with ``--seed 1``) must agree with it. Tasks and
methods are the registries' (``maopg.tasks``,
``maopg.experiment.run.methods``), extended by plugins (``--import MODULE``), which the run records
so that ``--resume`` and evaluation import them again.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import maopg  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)
from maopg.sim.egl_check import exit_if_mujoco_cannot_import

# One line, not PyOpenGL's traceback from the imports below:
exit_if_mujoco_cannot_import("python -m train")

from maopg.experiment.cli.command_line import (
    Parser,
    add_common_options,
    command_name,
    run_command,
)
from maopg.experiment.run.config import (
    TrainConfig,
    merge,
    parse_overrides,
    split_assignment,
    unset_run,
)
from maopg.experiment.run.config_file import read_config_file
from maopg.experiment.run.directory import CONFIG
from maopg.experiment.run.methods import method_names
from maopg.experiment.run.settings_reference import settings_help
from maopg.plugins import load_plugins
from maopg.tasks import task_names

PROG = command_name("python -m train")


def build_parser() -> argparse.ArgumentParser:
    """The parser, its choices from the registries as they are now (plugins loaded)."""
    parser = Parser(
        prog=PROG,
        description="Train an option-based multi-agent policy (MAPPO, or the Mac-DQN baseline).",
        epilog="Extra arguments key=value override any config field (e.g. num_envs=8, "
        "num_workers=2, video=false, plot=false, device=cuda), SECTION.key=value a "
        "hyper-parameter of the method's learner (ppo.epochs=5, dqn.lr=1e-3) and env.key=value "
        "a task setting; they override --config FILE. A key=value that repeats a flag "
        "(seed=2 with --seed 1) must agree with it. The settings follow.",
        more_help=settings_help,
    )
    parser.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="settings from a YAML or JSON file, the keys of a run's config.json (sections "
        "nested or dotted: ppo.epochs, env.max_ticks); key=value and flags override it",
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


FLAGS = {
    "task": "--task",
    "method": "--method",
    "seed": "--seed",
    "total_samples": "--total-samples",
    "run_dir": "--run-dir",
    "images": "--images",
}
"""The config fields that have a flag of their own; ``key=value`` may repeat one, not
contradict it."""


def parse_args(
    argv: Sequence[str] | None = None, plugins: Sequence[str] = ()
) -> tuple[TrainConfig, argparse.Namespace]:
    """The run's config from ``argv`` (without ``--import``: ``plugins`` are the modules that
    were imported for it): the defaults (on ``--resume``, the run's saved config), then the
    ``--config`` file, then ``key=value``, then the flags."""
    parser = build_parser()
    args = parser.parse_intermixed_args(argv)
    named = {key: getattr(args, key) for key in FLAGS if getattr(args, key) is not None}
    from_file = read_config_file(args.config) if args.config else {}
    given = dict(split_assignment(item) for item in args.overrides)
    # method=NAME (or a file's method) works like --method: it picks the section
    method = named.get("method", given.get("method", from_file.get("method")))
    base = unset_run(method or TrainConfig.method)
    if args.resume:
        # A resumed run starts from its saved config (and its plugins, imported before the
        # config is read: its task or method may be theirs); flags must agree with it.
        probe = TrainConfig.from_dict(merge(merge(base, from_file), named)).resolved()
        saved = Path(probe.run_dir) / CONFIG  # type: ignore[arg-type]
        if saved.exists():
            load_plugins(_saved_plugins(saved))
            base = TrainConfig.load(saved).to_dict()
            if method and method != base["method"]:  # else: its section would not fit
                raise ValueError(
                    f"--resume of {saved.parent}: the config differs from the saved one in "
                    f"method (saved {base['method']!r}, given {method!r})"
                )
    values = parse_overrides(args.overrides, method or base["method"])
    for key, flag in FLAGS.items():
        if key in named and key in values and values[key] != named[key]:
            shown = flag if named[key] is not False else "--no-images"
            shown += "" if isinstance(named[key], bool) else f" {named[key]}"
            raise ValueError(f"{shown} contradicts {key}={given[key]}")
    merged = {**merge(merge(base, from_file), values), **named}
    merged["plugins"] = list(
        dict.fromkeys([*base.get("plugins", []), *from_file.get("plugins", []), *plugins])
    )
    return TrainConfig.from_dict(merged), args


def _saved_plugins(path: Path) -> list[str]:
    return list(read_config_file(path).get("plugins", []))


def _early_plugins(argv: Sequence[str]) -> list[str]:
    """The plugins of the ``--config`` file and of the run that ``--resume --run-dir DIR``
    continues, imported before the parser is built: its ``--task`` / ``--method`` may be
    theirs."""
    early = argparse.ArgumentParser(add_help=False)
    early.add_argument("--resume", action="store_true")
    early.add_argument("--run-dir")
    early.add_argument("--config")
    known, _ = early.parse_known_args(argv)
    saved = Path(known.run_dir) / CONFIG if known.resume and known.run_dir else None
    files = [Path(known.config)] if known.config else []
    files += [saved] if saved is not None and saved.exists() else []
    return [plugin for path in files for plugin in _saved_plugins(path)]


def _train(argv: list[str], plugins: list[str]) -> int:
    plugins = [*plugins, *load_plugins(_early_plugins(argv))]
    config, args = parse_args(argv, list(dict.fromkeys(plugins)))
    from maopg.experiment.training.trainer import run_summary, train

    run_dir = train(config, resume=args.resume, overwrite=args.overwrite)
    print(run_summary(run_dir))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_command(PROG, argv, _train)


if __name__ == "__main__":
    sys.exit(main())
