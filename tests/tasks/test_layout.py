"""Named observation layouts: slices by name, checks, and what the tasks declare."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from maopg.env.contract import AgentSpec
from maopg.tasks.layout import ObsLayout


def test_fields_are_consecutive_slices_in_declaration_order() -> None:
    layout = ObsLayout.of(levels=3, elapsed=3, position=2)
    assert layout.names == ("levels", "elapsed", "position") and layout.size == 8
    assert layout["levels"] == slice(0, 3) and layout["position"] == slice(6, 8)
    vector = np.arange(8, dtype=np.float32)
    parts = layout.split(vector)
    assert list(parts) == list(layout.names)
    assert parts["elapsed"].tolist() == [3.0, 4.0, 5.0]
    parts["position"][:] = -1.0  # views: writing a field writes the vector
    assert vector[-2:].tolist() == [-1.0, -1.0]
    zeros = layout.zeros()
    assert zeros.dtype == np.float32 and zeros.shape == (8,) and not zeros.any()


def test_mistakes_are_named() -> None:
    layout = ObsLayout.of(levels=3)
    with pytest.raises(KeyError, match=r"no observation field 'level'; fields: \['levels'\]"):
        layout["level"]
    with pytest.raises(ValueError, match="appears twice"):
        ObsLayout((("a", 1), ("a", 2)))
    with pytest.raises(ValueError, match="positive size"):
        ObsLayout.of(a=0)
    with pytest.raises(ValueError, match="expected a vector of 3 values, got 4"):
        layout.split(np.zeros(4))


def test_layouts_compare_hash_and_pickle_by_their_fields() -> None:
    a, b = ObsLayout.of(x=2, y=1), ObsLayout((("x", 2), ("y", 1)))
    assert a == b and hash(a) == hash(b) and a != ObsLayout.of(y=1, x=2)
    copy = pickle.loads(pickle.dumps(a))  # specs travel to worker processes
    assert copy == a and copy["y"] == slice(2, 3)


def test_an_agent_spec_refuses_a_layout_of_another_size() -> None:
    layout = ObsLayout.of(x=2)
    assert AgentSpec("a", "turtlebot", ("o",), 2, layout).layout is layout
    assert AgentSpec("a", "turtlebot", ("o",), 2).layout is None  # unnamed vectors still work
    with pytest.raises(ValueError, match=r"agent 'a': layout .* has 2 values, vector_size is 3"):
        AgentSpec("a", "turtlebot", ("o",), 3, layout)
