"""Evaluate, film, plot, tabulate and reproduce trained policies (``python -m eval``).

Installed, the same command line is ``maopg-eval``.

python -m eval evaluate --checkpoint runs/tool_delivery/async/seed0 --episodes 20
python -m eval evaluate --reference scripted --task tool_delivery --episodes 10
python -m eval evaluate --reference scripted --task tool_delivery env.turtlebot_robot=diffbot
python -m eval video --checkpoint runs/tool_delivery/async/seed0 --out out/td_async.mp4
python -m eval evaluate --checkpoint runs/tool_delivery/async/seed0 env.appearance=heldout
python -m eval timeline --checkpoint runs/tool_delivery/async/seed0 --out out/td_async.png
python -m eval plot runs/ --out out/plots
python -m eval plot runs/ --reference-episodes 0     # no scripted / random reference lines
python -m eval table runs/ --threshold tool_delivery=200
python -m eval check-robot --robot drone --role drone
python -m eval reproduce              # the committed grid: results/runs → results/
python -m eval reproduce --tasks tool_delivery ppo.epochs=5 --config grid.yaml
python -m eval reproduce --study vision --dry-run   # see --list-studies

Settings are written as on the train command line: ``key=value`` arguments (task settings
``env.KEY=VALUE``) anywhere on the line; ``--set`` of earlier releases is refused with the new
spelling. A checkpoint's environment is its run's, with the task settings given on top where
its policy can still act (``env.appearance=heldout``: looks it never trained on).
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import maopg  # noqa: F401  (sets MUJOCO_GL=egl before anything imports mujoco)
from maopg.sim.egl_check import exit_if_mujoco_cannot_import

# One line, not PyOpenGL's traceback from the imports below:
exit_if_mujoco_cannot_import("python -m eval")

from maopg.env.contract import Strategy
from maopg.env.rollout import REFERENCE_POLICIES
from maopg.experiment.cli.command_line import (
    Parser,
    add_common_options,
    at_least,
    command_name,
    run_command,
)
from maopg.experiment.evaluation import GREEDY_BY_DEFAULT
from maopg.sim.checks import add_check_robot_arguments, cmd_check_robot

PROG = command_name("python -m eval")


def _policy_args(parser: argparse.ArgumentParser) -> None:
    from maopg.experiment.run.config import DEVICES

    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--checkpoint", type=Path, help="checkpoint file or run directory")
    source.add_argument("--reference", choices=REFERENCE_POLICIES, help="reference policy")
    parser.add_argument("--task", help="task of a reference policy (default tool_delivery)")
    parser.add_argument(
        "--strategy",
        choices=[s.value for s in Strategy],
        help="strategy of a reference policy (default continue)",
    )
    _settings_args(
        parser,
        "env.KEY=VALUE",
        "task settings of the environment: a reference policy's (env.turtlebot_robot=diffbot), "
        "or over a checkpoint's run where its policy can act (env.appearance=heldout)",
    )
    parser.add_argument("--seed", type=at_least(0), default=0)
    acting = parser.add_mutually_exclusive_group()
    flag = "--greedy" if GREEDY_BY_DEFAULT else "--sample"
    default = f"; default {flag}, maopg.experiment.evaluation.GREEDY_BY_DEFAULT says why"
    acting.add_argument(
        "--greedy",
        dest="sample",
        action="store_false",
        help=f"each agent takes its most probable option (Mac-DQN: ε 0){default}",
    )
    acting.add_argument(
        "--sample",
        dest="sample",
        action="store_true",
        help=f"sample options as in training (Mac-DQN: ε-greedy at its final ε){default}",
    )
    parser.set_defaults(sample=not GREEDY_BY_DEFAULT)
    parser.add_argument(
        "--device",
        choices=DEVICES,
        default="cpu",
        help="where a checkpoint's policy runs (default cpu: it acts on one point at a time, "
        "and evaluations on the CPU are bit-reproducible)",
    )


def _progress_arg(parser: argparse.ArgumentParser, over: str) -> None:
    """``--no-progress``: every subcommand that takes long shows a bar (over ``over``)."""
    parser.add_argument(
        "--no-progress", action="store_true", help=f"no progress bar over {over} (stderr)"
    )


EVAL_EPISODES = 10
"""``eval reproduce``'s episodes per trained policy in a study's ``evaluation.md``."""
REFERENCE_EPISODES = 10
"""``eval plot``'s episodes per reference policy: a level to read the curves against, in a few
seconds per task (``eval reproduce`` measures its tables' with 100)."""


SETTING = re.compile(r"^([A-Za-z_][\w.]*)=")
"""A ``key=value`` argument."""


SETTINGS_COMMANDS = ("evaluate", "video", "timeline", "reproduce")
"""The subcommands that take ``key=value`` settings."""


def _split_settings(argv: list[str]) -> tuple[list[str], list[str]]:
    """``(settings, the rest)``: for a subcommand that takes settings, the ``key=value`` items
    wherever they stand, so that a list option (``--methods a b``) does not swallow those after
    it; a ``TASK=VALUE`` (a registered task's name: ``--threshold``'s values) is no setting."""
    from maopg.tasks import task_names

    command = next((item for item in argv if not item.startswith("-")), None)
    if command not in SETTINGS_COMMANDS:
        return [], argv
    tasks = set(task_names())
    settings = []
    for item in argv:
        match = SETTING.match(item)
        if match and match.group(1) not in tasks:
            settings.append(item)
    return settings, [item for item in argv if item not in settings]


def _settings_args(parser: argparse.ArgumentParser, metavar: str, text: str) -> None:
    """The ``key=value`` arguments of a subcommand, and the retired ``--set`` (an error)."""
    parser.add_argument("settings", nargs="*", default=[], metavar=metavar, help=text)
    parser.add_argument("--set", nargs="*", default=None, help=argparse.SUPPRESS)


def _retired_set(args: argparse.Namespace, prefix: str) -> None:
    """``--set`` (an earlier release's spelling) is an error that shows the new one."""
    if args.set is not None:
        items = [item.removeprefix(prefix) for item in args.set or args.settings]
        new = " ".join(prefix + item for item in items) or f"{prefix}KEY=VALUE"
        raise ValueError(f"--set is retired: write the settings as arguments, {new}")


def _task_settings(args: argparse.Namespace) -> dict[str, Any]:
    """``env.KEY=VALUE`` arguments → a reference policy's task settings."""
    from maopg.experiment.run.config import parse_task_settings

    _retired_set(args, "env.")
    for item in args.settings:
        if not item.startswith("env."):
            raise ValueError(
                f"{item}: {args.command} takes task settings only, written env.KEY=VALUE"
            )
    return parse_task_settings([item.removeprefix("env.") for item in args.settings])


def _policy_and_env(args: argparse.Namespace):
    """``(label, who, env, policy, acting)`` for a checkpoint or a reference policy: ``label``
    names it in a results table, ``who`` in a video's title (the training seed and
    greedy/sampled of a checkpoint's policy, the name of a reference one), ``acting`` in an
    evaluation's record (:mod:`maopg.experiment.evaluation.provenance`)."""
    from maopg.env import make_env
    from maopg.env.rollout import reference_policy
    from maopg.experiment.evaluation.provenance import checkpoint_acting, reference_acting

    settings = _task_settings(args)
    if args.checkpoint is not None:
        from maopg.experiment.evaluation.loading import load_trained

        given = [f"--{k}" for k in ("task", "strategy") if getattr(args, k)]
        if given:
            raise ValueError(
                f"{', '.join(given)}: a checkpoint brings its own task and strategy "
                "(they apply to --reference policies only)"
            )
        trained = load_trained(args.checkpoint, device=args.device)
        env = trained.make_env(args.seed, settings)
        policy = trained.actor(greedy=not args.sample, seed=args.seed)
        c = trained.config
        label = f"{c.method} seed{c.seed} @ {trained.samples} samples"
        acting = checkpoint_acting(trained, greedy=not args.sample)
        return label, trained.label(greedy=not args.sample), env, policy, acting
    from maopg.tasks import task_class
    from maopg.tasks.base import require_strategy

    task, strategy = args.task or "tool_delivery", args.strategy or "continue"
    require_strategy(task_class(task), task, strategy)
    env = make_env(task, strategy, seed=args.seed, overrides=settings)
    policy = reference_policy(args.reference, env, args.seed)
    return args.reference, args.reference, env, policy, reference_acting(args.reference)


THRESHOLD = "--threshold"


def _threshold_arg(parser: argparse.ArgumentParser) -> None:
    """``--threshold TASK=VALUE``, once per task: taking one value, it leaves the run
    directories after it to the command (:func:`_one_threshold_each` reads the list form)."""
    parser.add_argument(
        THRESHOLD,
        action="append",
        default=[],
        metavar="TASK=VALUE",
        help="a task's return threshold for the samples-to-threshold table, over the study's "
        "(repeatable: --threshold tool_delivery=200 --threshold water_filling=-500)",
    )


def _one_threshold_each(argv: list[str]) -> list[str]:
    """``--threshold A=1 B=2`` (a list, as earlier releases took it) as ``--threshold A=1
    --threshold B=2``: after a threshold, each ``TASK=VALUE`` of a registered task is one
    more, so ``--threshold A=1 B=2 RUNS`` and ``--threshold A=1 B=2 -- RUNS`` both work."""
    from maopg.tasks import task_names

    tasks = set(task_names())
    out: list[str] = []
    listing = False
    for item in argv:
        match = SETTING.match(item)
        if listing and match and match.group(1) in tasks:
            out += [THRESHOLD, item]
            continue
        listing = out[-1:] == [THRESHOLD] or item.startswith(f"{THRESHOLD}=")
        out.append(item)
    return out


def _thresholds(items: list[str]) -> dict[str, float]:
    from maopg.experiment.run.config import split_assignment

    out = {}
    for item in items:
        try:
            task, value = split_assignment(item)
            out[task] = float(value)
        except ValueError as err:
            raise ValueError(f"--threshold expects TASK=VALUE: {err}") from None
        if "." in task:
            raise ValueError(f"--threshold {item}: {task!r} is no task name")
    return out


def cmd_evaluate(args: argparse.Namespace) -> int:
    from maopg.experiment.evaluation.evaluate import (
        choices_lines,
        evaluate,
        results_table,
        write_result,
    )
    from maopg.experiment.evaluation.provenance import provenance

    label, _, env, policy, acting = _policy_and_env(args)
    try:
        result = evaluate(
            env, policy, args.episodes, seed=args.seed, label=label, progress=not args.no_progress
        )
        result.source = provenance(env, acting)
    finally:
        env.close()
    print(results_table([result.summary]), end="")
    print("\n".join(["options chosen:", *choices_lines(result)]))
    if args.json:
        print(f"wrote {write_result(result, args.json)}")
    return 0


def cmd_video(args: argparse.Namespace) -> int:
    from maopg.env.video import FPS, record_episode

    _, who, env, policy, _ = _policy_and_env(args)
    try:
        video = record_episode(
            env,
            policy,
            args.out,
            seed=args.seed,
            fps=args.fps or FPS,
            policy_label=who,
            progress=not args.no_progress,
        )
    finally:
        env.close()
    cut = f" (cut at {video.ticks} ticks, the episode went on)" if video.cut else ""
    print(
        f"{video.path}: {video.frames} frames {video.shape[1]}x{video.shape[0]}, "
        f"return {video.ret:.1f} in {video.ticks} ticks, solved {video.solved}{cut}"
    )
    return 0


def cmd_timeline(args: argparse.Namespace) -> int:
    from maopg.experiment.evaluation.timeline import check_out, write_timeline

    check_out(args.out)
    _, who, env, policy, _ = _policy_and_env(args)
    try:
        path, played = write_timeline(env, policy, args.out, seed=args.seed, policy_label=who)
    finally:
        env.close()
    print(f"{path}: options of {len(played.rows)} agents over {played.ticks} ticks")
    return 0


def _which(args: argparse.Namespace) -> str:
    if args.unfinished:
        return "(config.json + metrics.csv)"
    return "finished (config.json + metrics.csv + done.json; --unfinished for runs in progress)"


def cmd_plot(args: argparse.Namespace) -> int:
    from maopg.experiment.studies.plots import plot_all
    from maopg.experiment.studies.runs import discover_runs

    runs = discover_runs(args.runs, unfinished=args.unfinished)
    if not runs:
        raise ValueError(f"no {_which(args)} run directories under {args.runs}")
    references = None
    if args.reference_episodes > 0 and args.metric == "episode_return":
        from maopg.experiment.studies.results import reference_lines

        plotted = [r for r in runs if args.methods is None or r.method in args.methods]
        references, notes = reference_lines(
            plotted, args.reference_episodes, progress=not args.no_progress
        )
        for note in notes:
            print(note)
    for path in plot_all(
        runs,
        args.out,
        metric=args.metric,
        window=args.window,
        methods=args.methods,
        references=references,
    ):
        print(f"wrote {path}")
    return 0


def cmd_table(args: argparse.Namespace) -> int:
    from maopg.experiment.studies import declared_thresholds
    from maopg.experiment.studies.runs import discover_runs
    from maopg.experiment.studies.tables import peak_table, threshold_table

    runs = discover_runs(args.runs, unfinished=args.unfinished)
    if not runs:
        raise ValueError(f"no {_which(args)} run directories under {args.runs}")
    thresholds = {**declared_thresholds(), **_thresholds(args.threshold)}
    text = (
        "## Peak performance\n\n"
        + peak_table(runs, window=args.window, methods=args.methods)
        + "\n## Samples to threshold\n\n"
        + threshold_table(runs, thresholds, window=args.window, methods=args.methods)
    )
    print(text, end="")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
        print(f"wrote {args.out}")
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    from maopg.experiment.studies import (
        LEADERBOARD,
        LEADERBOARD_ABOUT,
        VISION,
        VISION_ABOUT,
        get_study,
        study_names,
    )
    from maopg.experiment.studies.results import reproduce

    _retired_set(args, "")
    if args.list_studies:
        for name in study_names():
            study = get_study(name)
            tasks = ", ".join(f"{t.task} ({len(t.seeds)} seeds)" for t in study.tasks)
            print(f"{name}: {study.about}\n  tasks: {tasks}\n  methods: {' '.join(study.methods)}")
        print(f"{LEADERBOARD}: {LEADERBOARD_ABOUT}")
        print(f"{VISION}: {VISION_ABOUT}")
        return 0
    if args.study == LEADERBOARD:
        return _reproduce_leaderboard(args)
    if args.study == VISION:
        return _reproduce_vision(args)
    study = get_study(args.study)
    outcomes, written = reproduce(
        args.runs or study.runs_dir(),
        args.results or study.results_dir(),
        study=study,
        thresholds=_thresholds(args.threshold),
        window=args.window,
        train=not args.no_train,
        eval_episodes=EVAL_EPISODES if args.eval_episodes is None else args.eval_episodes,
        reference_episodes=args.reference_episodes,
        tasks=args.tasks,
        methods=args.methods,
        seeds=args.seeds,
        overrides=args.settings,
        config_file=args.config,
        in_process=args.in_process,
        jobs=args.jobs,
        dry_run=args.dry_run,
    )
    return _report(outcomes, written)


def _refuse_options(
    args: argparse.Namespace, study: str, refused: Sequence[str], why: str, allowed: str
) -> None:
    """One line for the first of ``refused`` (option names) given to ``--study study``, which
    keeps what they change fixed (``why``), naming the options it takes (``allowed``)."""
    given = {
        "--runs": args.runs,
        "--tasks": args.tasks,
        "--methods": args.methods,
        "--seeds": args.seeds,
        "--config": args.config,
        "--threshold": args.threshold,
        "key=value": args.settings,
    }
    for name in refused:
        if given[name]:
            raise ValueError(
                f"{name} does not apply to --study {study} ({why}); allowed: {allowed}"
            )


def _reproduce_leaderboard(args: argparse.Namespace) -> int:
    """``reproduce --study leaderboard``: its boards keep their studies' tasks, seeds and
    settings, so the options that change those are refused."""
    from maopg.experiment.studies import LEADERBOARD
    from maopg.experiment.studies.leaderboard import reproduce_leaderboard

    _refuse_options(
        args,
        LEADERBOARD,
        ("--runs", "--tasks", "--seeds", "--config", "--threshold", "key=value"),
        "its boards keep their studies' runs, tasks, seeds and settings",
        "--results, --methods, --jobs, --in-process, --dry-run, --no-train, --reference-episodes",
    )
    outcomes, written = reproduce_leaderboard(
        args.results or Path("results", LEADERBOARD),
        methods=args.methods,
        train=not args.no_train,
        reference_episodes=args.reference_episodes,
        in_process=args.in_process,
        jobs=args.jobs,
        dry_run=args.dry_run,
    )
    return _report(outcomes, written)


def _reproduce_vision(args: argparse.Namespace) -> int:
    """``reproduce --study vision``: its variants fix the method, the seeds and the settings;
    ``--tasks`` trains a subset first, ``--eval-episodes`` sets each evaluation's episodes."""
    from maopg.experiment.studies import VISION
    from maopg.experiment.studies.vision import EPISODES, reproduce_vision

    _refuse_options(
        args,
        VISION,
        ("--methods", "--seeds", "--config", "--threshold", "key=value"),
        "its variants fix the method, seeds and settings",
        "--results, --runs, --tasks, --jobs, --in-process, --dry-run, --no-train, "
        "--eval-episodes, --reference-episodes, --window",
    )
    outcomes, written = reproduce_vision(
        args.results or Path("results", VISION),
        runs_root=args.runs,
        tasks=args.tasks,
        train=not args.no_train,
        episodes=EPISODES if args.eval_episodes is None else args.eval_episodes,
        reference_episodes=args.reference_episodes,
        window=args.window,
        in_process=args.in_process,
        jobs=args.jobs,
        dry_run=args.dry_run,
    )
    return _report(outcomes, written)


def _report(outcomes: Mapping[object, str], written: Sequence[Path]) -> int:
    """Print the files written and the grid's outcomes; 1 if a cell failed."""
    for path in written:
        print(f"wrote {path}")
    failed = [c for c, o in outcomes.items() if o.startswith("failed")]
    counts: dict[str, int] = {}
    for outcome in outcomes.values():
        key = outcome.split(":")[0]
        counts[key] = counts.get(key, 0) + 1
    if counts:  # --no-train trains nothing and says nothing of it
        print("grid: " + ", ".join(f"{n} {k}" for k, n in sorted(counts.items())))
    return 1 if failed else 0


def build_parser() -> argparse.ArgumentParser:
    from maopg.experiment.run.methods import method_names
    from maopg.experiment.studies import LEADERBOARD, PAPER, VISION, get_study, study_names

    paper = get_study(PAPER)

    parser = Parser(prog=PROG, description=__doc__.split("\n")[0])
    add_common_options(parser)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("evaluate", help="mean ± std return etc. over N seeded episodes")
    _policy_args(p)
    p.add_argument("--episodes", type=at_least(1), default=20)
    p.add_argument("--json", type=Path, help="also write the result as JSON here")
    _progress_arg(p, "the episodes")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("video", help="record one episode as a headless MP4")
    _policy_args(p)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--fps", type=at_least(1), help="frames a second (default: four ticks a second)")
    _progress_arg(p, "the ticks")
    p.set_defaults(func=cmd_video)

    p = sub.add_parser("timeline", help="one episode's options per agent over time, as a figure")
    _policy_args(p)
    p.add_argument(
        "--out", type=Path, default=Path("timeline.png"), help="figure: .png, .svg or .pdf"
    )
    p.set_defaults(func=cmd_timeline)

    for name, func, text in (
        ("plot", cmd_plot, "learning curves (PNG + SVG) per task from run directories"),
        ("table", cmd_table, "Markdown peak / samples-to-threshold tables from run directories"),
    ):
        p = sub.add_parser(name, help=text)
        p.add_argument("runs", nargs="+", type=Path, help="run directories or their roots")
        p.add_argument(
            "--window", type=at_least(1), default=5, help="moving-mean window (iterations)"
        )
        p.add_argument("--methods", nargs="+", help="only these methods, in this order")
        p.add_argument("--unfinished", action="store_true", help="include runs still in progress")
        p.set_defaults(func=func)
        if name == "plot":
            p.add_argument("--out", type=Path, default=Path("results"))
            p.add_argument(
                "--metric",
                default="episode_return",
                choices=("episode_return", "option_step_reward", "eval_return"),
                help="eval_return: the evaluation during training, of runs trained with "
                "eval_every (default %(default)s)",
            )
            p.add_argument(
                "--reference-episodes",
                type=at_least(0),
                default=REFERENCE_EPISODES,
                metavar="N",
                help="episodes of the scripted and random policies at each task's settings, "
                "drawn as reference lines of the returns (default %(default)s; 0: no lines)",
            )
            _progress_arg(p, "the reference policies' episodes")
        else:
            _threshold_arg(p)
            p.add_argument("--out", type=Path, help="also write the Markdown here")

    p = sub.add_parser(
        "check-robot", help="a robot's controller checks in a test scene, with the figures"
    )
    add_check_robot_arguments(p)  # --robot NAME, --role ground|drone|arm, --timestep
    p.set_defaults(func=cmd_check_robot)  # exit status 0 if every check passes, else 1

    p = sub.add_parser(
        "reproduce", help="a study's resumable methods × tasks × seeds grid, then its results"
    )
    p.add_argument(
        "--study",
        default=PAPER,
        choices=[*study_names(), LEADERBOARD, VISION],
        help="which grid (default %(default)s: the paper's comparison; see --list-studies)",
    )
    p.add_argument("--list-studies", action="store_true", help="describe every study and exit")
    p.add_argument("--runs", type=Path, help="run root (default: the study's, results/runs)")
    p.add_argument("--results", type=Path, help="results folder (default: the study's, results)")
    p.add_argument("--tasks", nargs="+", help="a subset of the study's tasks")
    p.add_argument(
        "--methods",
        nargs="+",
        choices=method_names(),
        help=f"instead of the study's (paper: {' '.join(paper.methods)})",
    )
    p.add_argument(
        "--seeds",
        nargs="+",
        type=int,
        help="for every task (default: the study's; paper: "
        + ", ".join(f"{t.task} {len(t.seeds)} seeds" for t in paper.tasks)
        + ")",
    )
    _settings_args(
        p,
        "key=value",
        "train settings of every run, as on the train command line: num_envs=8, ppo.epochs=5, "
        "env.max_ticks=100 (keep them identical across resumptions)",
    )
    p.add_argument(
        "--config",
        type=Path,
        metavar="FILE",
        help="a YAML or JSON settings file given to every run's train command line",
    )
    _threshold_arg(p)
    p.add_argument("--window", type=at_least(1), default=5)
    p.add_argument(
        "--eval-episodes",
        type=at_least(0),
        help=f"episodes per trained policy in evaluation.md (default {EVAL_EPISODES}; 0: skip "
        "evaluation.md); --study vision: per look and way of acting (default 20)",
    )
    p.add_argument(
        "--reference-episodes",
        type=at_least(1),
        default=100,
        help="episodes per reference policy in evaluation.md",
    )
    p.add_argument("--in-process", action="store_true", help="train in this process")
    p.add_argument(
        "--jobs",
        type=at_least(1),
        default=1,
        help="cells trained at once, each in its own process (default 1; several reproduce "
        "invocations over one grid also share its cells out)",
    )
    p.add_argument("--dry-run", action="store_true", help="list what would run; train nothing")
    p.add_argument("--no-train", action="store_true", help="only regenerate figures and tables")
    p.set_defaults(func=cmd_reproduce)
    return parser


def _run(argv: list[str], plugins: list[str]) -> int:
    settings, rest = _split_settings(argv)
    args = build_parser().parse_args(_one_threshold_each(rest))
    if settings:
        args.settings = [*args.settings, *settings]
    return args.func(args)


def main(argv: Sequence[str] | None = None) -> int:
    """Run a subcommand; ``--import MODULE`` (anywhere, repeatable) loads plugins first."""
    return run_command(PROG, argv, _run)


if __name__ == "__main__":
    sys.exit(main())
