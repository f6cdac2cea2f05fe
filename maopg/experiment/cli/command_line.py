"""What the two command lines share: plugins before anything else, and user errors as one line.

Plugins (``--import MODULE``, repeatable, anywhere on the line; :mod:`maopg.plugins`) are
imported *before* the real parser is built, because the parser's choices — tasks, methods — are
the registries', which a plugin extends. A mistake of the user's ends the command with one line
naming it and exit status 2 (:mod:`maopg.experiment.run.errors`); ``--debug`` shows the
traceback instead.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from maopg.experiment.run.errors import reporting_user_errors
from maopg.plugins import load_plugins


class UsageError(ValueError):
    """A command line argparse refused (an unknown option, a bad choice or number)."""


class Parser(argparse.ArgumentParser):
    """argparse's parser, its usage errors user errors like any other: one line and status 2
    from :func:`run_command` (argparse would print the whole usage first). Subcommands'
    parsers are of the same class. ``more_help`` renders text that ``--help`` shows after the
    options, as it is, made only when asked for (the settings reference)."""

    def __init__(self, *args: Any, more_help: Callable[[], str] | None = None, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.more_help = more_help

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see {self.prog} --help)")

    def format_help(self) -> str:
        text = super().format_help()
        return f"{text}{self.more_help()}\n" if self.more_help else text


def command_name(module_command: str) -> str:
    """What the user typed to start the command, for its usage and error lines: the installed
    script's name (``maopg-train``) when it runs, else ``module_command`` (``python -m train``,
    a clone's ``train/__main__.py``; also what tests calling ``main`` see)."""
    script = Path(sys.argv[0]).name
    return script if script.startswith("maopg-") else module_command


def at_least(minimum: int) -> Callable[[str], int]:
    """An argparse ``type``: an integer >= ``minimum`` (a seed: 0; a count: 1)."""

    def integer(text: str) -> int:
        value = int(text)
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        return value

    return integer


def preparse(argv: Sequence[str] | None) -> tuple[argparse.Namespace, list[str]]:
    """``--import`` and ``--debug`` out of ``argv``; the rest is for the command's parser."""
    early = argparse.ArgumentParser(add_help=False)
    early.add_argument("--import", dest="plugins", action="append", default=[])
    early.add_argument("--debug", action="store_true")
    known, rest = early.parse_known_args(list(sys.argv[1:] if argv is None else argv))
    return known, rest


def add_common_options(parser: argparse.ArgumentParser) -> None:
    """Document ``--import`` and ``--debug`` in ``--help`` (:func:`preparse` reads them)."""
    parser.add_argument(
        "--import",
        dest="plugins",
        action="append",
        default=[],
        metavar="MODULE",
        help="import MODULE (or a .py file) first: it may register tasks, robots, methods "
        "(repeatable; see also MAOPG_PLUGINS)",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks of user errors")


def run_command(
    prog: str, argv: Sequence[str] | None, command: Callable[[list[str], list[str]], int]
) -> int:
    """Load the plugins of ``argv``, then ``command(remaining arguments, plugins imported by
    name)``; a user error prints ``prog: error: ...`` and returns 2 (unless ``--debug``)."""
    early, rest = preparse(argv)
    return reporting_user_errors(
        prog, lambda: command(rest, load_plugins(early.plugins)), debug=early.debug
    )
