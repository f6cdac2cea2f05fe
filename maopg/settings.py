"""Typed, range-checked config dataclasses: each field declares its bounds where it is defined.

Every config of the project — the run's fields, the learners' sections, the Ray backend's and
every task's settings — subclasses :class:`Settings`. Its ``__post_init__`` checks each field
once, when the config is made (from a command line, a config file or a saved ``config.json``),
so a bad value fails before anything is built or written, with one line that names the setting
as the user writes it (``env.max_ticks``, ``ppo.clip``):

- the value's kind against the annotation (``int``, ``float``, ``bool``, ``str``, fixed-length
  tuples of them, ``X | None``; other annotations are checked with ``isinstance`` of their
  origin, ``Any`` not at all). A bool is no int, an int is a float; a list given for a tuple
  (JSON has no tuples) is stored as the tuple;
- NaN in any float, always (it is never a setting), and ±inf unless the field says
  ``infinite=True`` (a limit where inf means "none");
- the bounds declared with :func:`setting` (``ge``, ``gt``, ``le``, ``lt``, ``choices``,
  ``increasing``), applied to the number or to every number of a tuple.

A config declares a field with bounds as ``max_ticks: int = setting(150, ge=1)``. A subclass
that only changes a default (``max_ticks: int = 300``) keeps the bounds its base declared.
Relations between fields go in an override of :meth:`Settings.validate` that calls
``super().validate()`` first. ``PREFIX`` is how the user names the config's section
(``"ppo."``).
"""

from __future__ import annotations

import dataclasses
import difflib
import itertools
import math
import operator
import types
from collections.abc import Iterable, Sequence
from dataclasses import MISSING, dataclass
from functools import cache
from typing import Any, ClassVar, Union, get_args, get_origin, get_type_hints

BOUNDS = "maopg.bounds"
"""The key of a field's :class:`Bounds` in its ``metadata``."""


@dataclass(frozen=True)
class Bounds:
    """What :func:`setting` declares about a field's values (``None``: no such bound)."""

    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    choices: tuple[Any, ...] | None = None
    infinite: bool = False
    """±inf is allowed (a limit where inf means "no limit")."""
    increasing: bool = False
    """A tuple's numbers must increase strictly (a range ``(low, high)``)."""

    def problem(self, value: Any) -> str | None:
        """What is wrong with ``value`` (a number, a tuple of numbers or a choice), or ``None``."""
        if self.choices is not None and value not in self.choices:
            return f"must be one of {list(self.choices)}"
        numbers = _numbers(value)
        for bound, holds, word in (
            (self.ge, operator.ge, ">="),
            (self.gt, operator.gt, ">"),
            (self.le, operator.le, "<="),
            (self.lt, operator.lt, "<"),
        ):
            if bound is not None and not all(holds(x, bound) for x in numbers):
                return f"must be {word} {bound:g}"
        if self.increasing and any(a >= b for a, b in itertools.pairwise(numbers)):
            return "must increase (low < high)"
        return None

    def describe(self) -> str:
        """What the bounds allow, as the settings reference lists it (``>= 1``, ``one of a,
        b``, ``> 0, inf allowed``); empty where they allow anything of the kind."""
        parts = [
            f"{word} {bound:g}"
            for bound, word in ((self.ge, ">="), (self.gt, ">"), (self.le, "<="), (self.lt, "<"))
            if bound is not None
        ]
        if self.choices is not None:
            parts.append("one of " + ", ".join(str(choice) for choice in self.choices))
        if self.increasing:
            parts.append("increasing")
        if self.infinite:
            parts.append("inf allowed")
        return ", ".join(parts)


def setting(
    default: Any = MISSING,
    *,
    default_factory: Any = MISSING,
    ge: float | None = None,
    gt: float | None = None,
    le: float | None = None,
    lt: float | None = None,
    choices: Sequence[Any] | None = None,
    infinite: bool = False,
    increasing: bool = False,
) -> Any:
    """A dataclass field whose values :class:`Settings` checks against these bounds."""
    bounds = Bounds(
        ge=ge,
        gt=gt,
        le=le,
        lt=lt,
        choices=None if choices is None else tuple(choices),
        infinite=infinite,
        increasing=increasing,
    )
    return dataclasses.field(
        default=default, default_factory=default_factory, metadata={BOUNDS: bounds}
    )


class Settings:
    """Base of the config dataclasses: every field checked on creation (module docstring)."""

    PREFIX: ClassVar[str] = ""
    """How the user writes a field of this config: ``PREFIX + name`` (``"ppo."``, ``"env."``)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check every field (``ValueError`` naming the first bad one); a config that was changed
        after creation (``TrainConfig.resolved``) calls it again. Overrides add relations
        between fields after ``super().validate()``."""
        hints = field_hints(type(self))
        for item in dataclasses.fields(self):  # type: ignore[arg-type]
            name = self.PREFIX + item.name
            value = getattr(self, item.name)
            hint = hints.get(item.name, Any)
            if not _conforms(value, hint):
                raise ValueError(f"{name} expected {describe_kind(hint)}, got {value!r}")
            normal = _as_tuples(value, hint)
            if normal is not value:
                object.__setattr__(self, item.name, normal)
            bounds = field_bounds(type(self), item.name)
            for x in _numbers(normal):
                if math.isnan(x) or (math.isinf(x) and not bounds.infinite):
                    raise ValueError(f"{name} must be a finite number, got {value!r}")
            if normal is not None:
                problem = bounds.problem(normal)
                if problem:
                    raise ValueError(f"{name} {problem}, got {value!r}")


NEAR = 0.6
"""How alike (:class:`difflib.SequenceMatcher` ratio) a known setting's field name must be to
an unknown one's to be suggested for it (difflib's own default)."""


def unknown_setting(name: str, known: Iterable[str], where: str = "") -> ValueError:
    """The error for a setting ``name`` (``ppo.epoch``) that none of the ``known`` ones is
    (``where`` says whose: `` of task 'x'``): one line with the known setting whose field name
    is nearest (``max_tick`` → ``env.max_ticks``; in its own section where two are as near),
    or the known settings of its section when none is near enough."""
    known = sorted(set(known))
    section, _, field = name.rpartition(".")

    def likeness(key: str) -> tuple[float, bool]:
        own_section, _, own_field = key.rpartition(".")
        return difflib.SequenceMatcher(None, field, own_field).ratio(), own_section == section

    nearest = max(known, key=likeness, default=None)
    if nearest is not None and likeness(nearest)[0] >= NEAR:
        return ValueError(f"unknown setting {name!r}{where}: did you mean {nearest!r}?")
    same = [key for key in known if key.rpartition(".")[0] == section]
    return ValueError(f"unknown setting {name!r}{where}; known: {', '.join(same or known)}")


@cache
def field_hints(cls: type) -> dict[str, Any]:
    """The fields' annotations; none where they do not resolve at run time (a name imported
    only for type checkers): the kinds then go unchecked, the bounds still apply."""
    try:
        return get_type_hints(cls)
    except (NameError, TypeError):
        return {}


@cache
def field_bounds(cls: type, name: str) -> Bounds:
    """The bounds the nearest class of ``cls``'s MRO declares for field ``name``."""
    for klass in cls.__mro__:
        declared = getattr(klass, "__dataclass_fields__", {}).get(name)
        if declared is not None and BOUNDS in declared.metadata:
            return declared.metadata[BOUNDS]
    return Bounds()


def _options(hint: Any) -> tuple[Any, ...]:
    """The members of a union annotation (``X | None``), else ``()``."""
    return get_args(hint) if get_origin(hint) in (Union, types.UnionType) else ()


def _conforms(value: Any, hint: Any) -> bool:
    """Whether ``value`` is of the kind ``hint`` annotates (module docstring)."""
    if hint is Any:
        return True
    if _options(hint):
        return any(_conforms(value, option) for option in _options(hint))
    if hint is type(None):
        return value is None
    if hint is bool:
        return isinstance(value, bool)
    if hint in (int, float):
        allowed = (int,) if hint is int else (int, float)
        return isinstance(value, allowed) and not isinstance(value, bool)
    origin = get_origin(hint)
    if origin is tuple:
        if not isinstance(value, list | tuple):
            return False
        args = get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return all(_conforms(v, args[0]) for v in value)
        return len(value) == len(args) and all(
            _conforms(v, a) for v, a in zip(value, args, strict=True)
        )
    kind = origin or hint
    return not isinstance(kind, type) or isinstance(value, kind)


def _as_tuples(value: Any, hint: Any) -> Any:
    """``value`` with the lists given for tuple annotations made tuples (``value`` itself when
    nothing changes)."""
    for option in _options(hint):
        if _conforms(value, option):
            return _as_tuples(value, option)
    if get_origin(hint) is not tuple or not isinstance(value, list | tuple):
        return value
    args = get_args(hint)
    inner = [args[0]] * len(value) if len(args) == 2 and args[1] is Ellipsis else args
    converted = tuple(_as_tuples(v, a) for v, a in zip(value, inner, strict=True))
    return value if converted == value and isinstance(value, tuple) else converted


def _numbers(value: Any) -> list[float]:
    """The numbers of a number or of a (nested) tuple, bools excluded."""
    if isinstance(value, bool):
        return []
    if isinstance(value, int | float):
        return [value]
    if isinstance(value, tuple):
        return [x for v in value for x in _numbers(v)]
    return []


def describe_kind(hint: Any) -> str:
    """``int``, ``float or null``, ``[float, float]``: the kind as the error line names it."""
    if _options(hint):
        return " or ".join(describe_kind(option) for option in _options(hint))
    if hint is type(None):
        return "null"
    if get_origin(hint) is tuple:
        args = get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"[{describe_kind(args[0])}, ...]"
        return "[" + ", ".join(describe_kind(a) for a in args) + "]"
    return getattr(get_origin(hint) or hint, "__name__", str(hint))
