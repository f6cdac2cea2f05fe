"""The docstrings' reStructuredText roles as the API reference's links (a griffe extension).

The code's docstrings name other objects the Sphinx way, ``:class:`~maopg.tasks.base.Task```,
``:func:`make_env```, ``:mod:`.run```, and introduce examples with ``::``. The site renders
docstrings as Markdown, where a role would show as ``:class:`` text: this extension turns each
into the object's name in code, linked to its entry in the API reference where the reference
documents it (an *optional* cross-reference: an object the reference leaves out stays plain
code instead of failing the strict build). ``~`` shows the last component only, as in Sphinx;
a relative (``.config.TrainConfig``) or bare (``OptionEnv``) name is resolved from the
docstring's own module and scope.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?:mod|class|func|meth|attr|data|exc|obj|const):`(~?)([^`]+)`")
"""A Sphinx role: ``:class:`~a.b.C``` (groups: the ``~``, the target)."""
LITERAL = re.compile(r"::$", re.MULTILINE)
"""reST's ``text::`` before an indented example (Markdown's indented code needs no marker)."""


def _identifier(obj: griffe.Object, target: str) -> str:
    """The full path of ``target`` as written in ``obj``'s docstring (unchanged if unknown)."""
    target = re.sub(r"\s+", "", target)  # a role wrapped over two lines
    module = obj if obj.is_module else obj.module
    if target.startswith("."):
        base = module if module.is_init_module else module.parent
        dots = len(target) - len(target.lstrip("."))
        for _ in range(dots - 1):
            base = base.parent if base is not None else None
        rest = target.lstrip(".")
        return f"{base.path}.{rest}" if base is not None else rest
    try:
        return obj.resolve(target.split(".")[0]) + target[len(target.split(".")[0]) :]
    except (griffe.NameResolutionError, ValueError, AttributeError):
        return target


def convert(obj: griffe.Object, text: str) -> str:
    """``text`` with its roles as optional cross-references and its ``::`` markers as ``:``."""

    def link(match: re.Match) -> str:
        short, target = match.groups()
        shown = re.sub(r"\s+", "", target)
        shown = shown.split(".")[-1] if short else shown.lstrip(".")
        return (
            f'<autoref identifier="{_identifier(obj, target)}" optional>'
            f"<code>{shown}</code></autoref>"
        )

    return LITERAL.sub(":", ROLE.sub(link, text))


class SphinxRoles(griffe.Extension):
    """Rewrite each object's docstring once the tree is complete (names resolve then)."""

    def on_object(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = convert(obj, obj.docstring.value)
