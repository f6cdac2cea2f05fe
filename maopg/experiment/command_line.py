"""What the two command lines share: plugins before anything else, and user errors as one line.

Plugins (``--import MODULE``, repeatable, anywhere on the line; :mod:`maopg.plugins`) are
imported *before* the real parser is built, because the parser's choices — tasks, methods — are
the registries', which a plugin extends. A mistake of the user's (a bad setting, a missing run
directory, a plugin that fails to import) ends the command with one line naming it and exit
status 2; ``--debug`` shows the traceback instead. A training run that went non-finite (NaN or
infinity in a loss, gradient or weight) ends the same way: its settings, not the code, are at
fault. So does a machine that cannot render what the command needs (``MUJOCO_GL`` and its
libraries, a display for ``glfw``): its setup, not the code.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import NoReturn

from maopg.learner import CheckpointError, NonFiniteError
from maopg.plugins import PluginError, load_plugins
from maopg.sim.render import RenderError


class UsageError(ValueError):
    """A command line argparse refused (an unknown option, a bad choice or number)."""


class Parser(argparse.ArgumentParser):
    """argparse's parser, its usage errors user errors like any other: one line and status 2
    from :func:`run_command` (argparse would print the whole usage first). Subcommands'
    parsers are of the same class."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{message} (see {self.prog} --help)")


def at_least(minimum: int) -> Callable[[str], int]:
    """An argparse ``type``: an integer >= ``minimum`` (a seed: 0; a count: 1)."""

    def integer(text: str) -> int:
        value = int(text)
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        return value

    return integer


USER_ERRORS = (
    ValueError,
    KeyError,
    FileNotFoundError,
    FileExistsError,
    NotADirectoryError,
    IsADirectoryError,
    PermissionError,
    CheckpointError,
    NonFiniteError,
    PluginError,
    RenderError,
)
"""What a user's input can cause (the path errors: a file or directory the user named); anything
else is a bug and keeps its traceback."""


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
    try:
        plugins = load_plugins(early.plugins)
        return command(rest, plugins)
    except USER_ERRORS as err:
        if early.debug:
            raise
        message = err.args[0] if isinstance(err, KeyError) and err.args else err
        print(f"{prog}: error: {message}", file=sys.stderr)
        return 2
