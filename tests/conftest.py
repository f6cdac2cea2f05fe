"""Shared test setup: import maopg first so MUJOCO_GL=egl is set before any test imports mujoco."""

import re
from collections.abc import Callable, Sequence

import pytest

import maopg  # noqa: F401


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files holding a ``slow`` test run first, each file's tests kept together and in
    order: ``scripts/test.sh`` hands whole files to its workers in this order
    (``--no-loadscope-reorder``), so the long ones start at once and the short ones even out
    the end, instead of a long file starting last on one worker while the other idles."""
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow)


@pytest.fixture
def user_error(capsys) -> Callable[[Callable[[Sequence[str]], int], Sequence[str], str], str]:
    """``user_error(main, argv, pattern)``: the command line ends with exit status 2 and one
    ``error:`` line matching ``pattern`` on stderr, no traceback; returns stderr."""

    def check(main: Callable[[Sequence[str]], int], argv: Sequence[str], pattern: str) -> str:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert re.search(pattern, err) and "Traceback" not in err, err
        return err

    return check


@pytest.fixture
def terminal(monkeypatch) -> None:
    """stderr taken for a terminal, as where a user watches a run: progress shows as tqdm bars
    (:mod:`maopg.progress`; under pytest it is captured, as in a log)."""
    from maopg import progress

    monkeypatch.setattr(progress, "on_terminal", lambda: True)
