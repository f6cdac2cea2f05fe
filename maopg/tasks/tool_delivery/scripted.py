"""The hand-written Tool Delivery policy: the reference level of the learning curves."""

from __future__ import annotations

import numpy as np

from maopg.tasks.scripting import DecisionView, ScriptedPolicy, option_finder
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import (
    AGENTS,
    FETCH,
    FETCH_OBS,
    GET_TOOL,
    GO_TO_WS,
    NUM_TOOLS,
    TURTLEBOT_OBS,
    TURTLEBOTS,
    WAIT,
    pass_to,
    search_tool,
)
from maopg.tasks.tool_delivery.options import option_sets


def scripted_policy(config: Config) -> ScriptedPolicy:
    """The reference policy, from the agents' own observations only.

    Turtlebots: carrying a tool -> GoToWS, else GetTool. Fetch: a tool staged and a Turtlebot
    ready -> PassTo(it); else search the next tool (in order) if the desk has room; else Wait.
    This reproduces the reference trace's decisions (canonical: return 259 in 41 ticks).
    """
    if config.primitive:
        raise ValueError("the scripted Tool Delivery policy drives options, not primitive actions")
    index = option_finder(option_sets(config), AGENTS)
    go_ws = [index(w, GO_TO_WS) for w in TURTLEBOTS]
    get_tool = [index(w, GET_TOOL) for w in TURTLEBOTS]
    passes = [index(FETCH, pass_to(w)) for w in TURTLEBOTS]
    searches = [index(FETCH, search_tool(j)) for j in range(NUM_TOOLS)]
    wait = index(FETCH, WAIT)
    carried, staged, waiting = TURTLEBOT_OBS["carried"], FETCH_OBS["staged"], FETCH_OBS["waiting"]
    searched = [0]  # tools whose search the policy has started this episode (its only memory)

    def act(point: DecisionView) -> np.ndarray:
        if point.ticks == 0:
            searched[0] = 0
        joint = point.running.copy()
        for w in TURTLEBOTS:
            joint[w] = go_ws[w] if point.vectors[w][carried].any() else get_tool[w]
        if point.choosing[FETCH]:
            fetch_obs = point.vectors[FETCH]
            ready = [w for w in TURTLEBOTS if fetch_obs[waiting][w] > 0]
            desk = fetch_obs[staged]  # one-hot: none, one, two or more tools staged
            if desk[0] == 0 and ready:
                joint[FETCH] = passes[ready[0]]
            elif searched[0] < NUM_TOOLS and desk[-1] == 0:  # a tool left, desk not full
                joint[FETCH] = searches[searched[0]]
                searched[0] += 1
            else:
                joint[FETCH] = wait
        return joint

    return act
