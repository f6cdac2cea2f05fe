"""The declared-bounds mechanism every config uses (:mod:`maopg.settings`), on a config of the
test's own: kinds, bounds, infinity, JSON lists, bounds kept by a subclass, cross-field rules."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import pytest

from maopg.settings import Settings, setting


@dataclass(frozen=True)
class Demo(Settings):
    PREFIX: ClassVar[str] = "demo."

    count: int = setting(3, ge=1)
    rate: float = setting(0.5, gt=0.0, le=1.0)
    limit: float = setting(10.0, gt=0.0, infinite=True)
    span: tuple[int, int] = setting((1, 5), ge=0, increasing=True)
    spot: tuple[float, float] | None = None
    mode: str = setting("a", choices=("a", "b"))
    flag: bool = False


@dataclass(frozen=True)
class Child(Demo):
    count: int = 7  # a new default keeps the base's bound

    def validate(self) -> None:
        super().validate()
        if self.count > 10 * self.span[1]:
            raise ValueError("demo.count must be <= 10 * demo.span[1]")


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"count": 0}, r"demo\.count must be >= 1, got 0"),
        ({"count": 2.0}, r"demo\.count expected int, got 2\.0"),
        ({"count": True}, r"demo\.count expected int, got True"),
        ({"rate": 0.0}, r"demo\.rate must be > 0, got 0\.0"),
        ({"rate": math.nan}, r"demo\.rate must be a finite number, got nan"),
        ({"rate": math.inf}, r"demo\.rate must be a finite number, got inf"),
        ({"span": (5, 1)}, r"demo\.span must increase \(low < high\), got \(5, 1\)"),
        ({"span": (-1, 1)}, r"demo\.span must be >= 0, got \(-1, 1\)"),
        ({"span": (1, 2, 3)}, r"demo\.span expected \[int, int\], got \(1, 2, 3\)"),
        ({"spot": "here"}, r"demo\.spot expected \[float, float\] or null, got 'here'"),
        ({"mode": "c"}, r"demo\.mode must be one of \['a', 'b'\], got 'c'"),
        ({"flag": 1}, r"demo\.flag expected bool, got 1"),
    ],
)
def test_a_bad_value_names_the_field_and_the_rule(changes, message):
    with pytest.raises(ValueError, match=message):
        Demo(**changes)


def test_good_values_pass_and_json_lists_become_tuples():
    demo = Demo(count=2, rate=1, limit=math.inf, span=[0, 9], spot=[1, 2.5], mode="b")
    assert demo.span == (0, 9) and demo.spot == (1, 2.5) and demo.limit == math.inf
    assert dataclasses.replace(demo, count=4).span == (0, 9)


def test_a_subclass_keeps_the_bounds_and_adds_relations():
    assert Child().count == 7
    with pytest.raises(ValueError, match=r"demo\.count must be >= 1, got 0"):
        Child(count=0)
    with pytest.raises(ValueError, match=r"demo\.count must be <= 10 \* demo\.span\[1\]"):
        Child(count=60)
