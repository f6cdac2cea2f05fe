"""The reference's scripted Box Pushing policy: both agents to the big box, then push it."""

from __future__ import annotations

import numpy as np

from maopg.tasks.box_pushing_grid.config import Config
from maopg.tasks.box_pushing_grid.options import option_set
from maopg.tasks.box_pushing_grid.world import LAYOUT, agent_names
from maopg.tasks.scripting import DecisionView, ScriptedPolicy, option_finder


def scripted_policy(config: Config) -> ScriptedPolicy:
    """Agent ``k`` of the two pushers issues ``GoToBigBox(left|right)`` until it stands on its
    waypoint facing north; there it issues Push if its partner stands on its own and chooses
    too (so both push on one tick, the joint push), else Stay. A third agent stays. Optimal: 4 /
    6 / 8 / 11 ticks and 299.6 / 299.4 / 299.2 / 298.9 on 4x4 / 6x6 / 8x8 / 10x10.

    The reference's policy reads the env state; this one reads what a decision point shows:
    an agent stands on its waypoint facing north when its last macro-action was its GoTo, a
    Stay or a Push and it sees the big box in front — which also holds under ``any``, where its
    GoTo is cut every tick and chosen again.
    """
    if config.primitive:
        raise ValueError(
            "the scripted Box Pushing policy drives macro-actions, not primitive actions"
        )
    find = option_finder([option_set(config)] * config.agents, agent_names(config.agents))
    spot = (find(0, "GoToBigBox(left)"), find(1, "GoToBigBox(right)"))
    push, stay = find(0, "Push"), find(0, "Stay")
    big_box = LAYOUT["big_box"]

    def act(point: DecisionView) -> np.ndarray:
        joint = point.running.copy()
        there = [
            bool(point.choosing[k])
            and int(point.running[k]) in (spot[k], stay, push)
            and point.vectors[k][big_box][0] > 0
            for k in (0, 1)
        ]
        for k in (0, 1):
            if point.choosing[k]:
                joint[k] = (push if there[1 - k] else stay) if there[k] else spot[k]
        joint[2:][point.choosing[2:]] = stay
        return joint

    return act
