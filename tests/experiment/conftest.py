"""The random team's levels the learning tests measure against, each computed once per test
process (the same seeded episodes every test reads)."""

import numpy as np
import pytest

from maopg.env.rollout import evaluate_reference


@pytest.fixture(scope="session")
def random_tool_delivery() -> float:
    """The uniform-random team's mean return on Tool Delivery over 40 seeded episodes
    (−57.3)."""
    return float(np.mean([r.ret for r in evaluate_reference("tool_delivery", "random", 40, 0)]))


@pytest.fixture(scope="session")
def random_grid4() -> float:
    """The uniform-random team's mean return on the 4x4 Box Pushing grid over 200 seeded
    episodes (about 1.6)."""
    returns = evaluate_reference("box_pushing_grid", "random", 200, 0, "continue", {"size": 4})
    return float(np.mean([r.ret for r in returns]))
