"""The hand-written Tool Delivery policy: the reference level of the learning curves."""

from __future__ import annotations

import numpy as np

from maopg.tasks.scripting import DecisionView, ScriptedPolicy, option_finder
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import NUM_TOOLS, WAIT, pass_to
from maopg.tasks.tool_delivery.options import option_sets
from maopg.tasks.tool_delivery.team import Team


def scripted_policy(config: Config) -> ScriptedPolicy:
    """The reference policy, from the agents' observations only, at any team size.

    Turtlebot ``w`` serves Fetch ``w % fetches``: carrying a tool -> GoToWS of the tool's human,
    else GetTool at its Fetch. Fetch: a tool staged and a Turtlebot ready -> PassTo(the first
    ready); else search its next tool if the desk has room (its tools in stage order,
    interleaving its humans, so each gets its next tool in turn); else Wait. At the canonical
    size this reproduces the reference trace's decisions (return 259 in 41 ticks).

    Three rules make it work under the sync strategies too, and change nothing under
    ``continue`` at the canonical size (the trace test checks it). A Turtlebot that re-chooses
    GetTool at its Fetch's desk counts as ready: where every option ended at once, no GetTool is
    running, so the Fetch's own ``waiting`` bits are all off. A search that ended without one
    tool more on the desk (cut short under ``any``) is done again. And where every agent chooses
    at once, a Fetch with nothing to do while another Fetch starts a search or a pass "searches"
    a tool it already found (a no-op as long as that) instead of Wait, which under ``any`` would
    cut the other's activity short every tick. With ``mask_options`` that search is masked (it
    cannot find a tool) and the Fetch waits.
    """
    if config.primitive:
        raise ValueError("the scripted Tool Delivery policy drives options, not primitive actions")
    team = Team.of(config)
    if team.turtlebots < team.fetches:
        raise ValueError(
            "the scripted Tool Delivery policy gives every Fetch its own Turtlebots: "
            f"turtlebots must be at least fetches, got {team.turtlebots} < {team.fetches}"
        )
    sets = option_sets(config)
    index = option_finder(sets, team.agents)
    fetch_agents = [team.fetch_agent(f) for f in team.fetch_ids]
    home = [w % team.fetches for w in team.turtlebot_ids]
    go_ws = [[index(w, team.go_to_ws(h)) for h in range(team.humans)] for w in team.turtlebot_ids]
    get_tool = [index(w, team.get_tool(home[w])) for w in team.turtlebot_ids]
    passes = [[index(a, pass_to(w)) for w in team.turtlebot_ids] for a in fetch_agents]
    # Each Fetch's tools in stage order, its humans interleaved: (h0, j0), (h2, j0), (h0, j1)...
    order = [sorted(team.tools_of(f), key=lambda t: (t % NUM_TOOLS, t)) for f in team.fetch_ids]
    searches = [
        [index(a, team.search_tool(t)) for t in order[f]] for f, a in enumerate(fetch_agents)
    ]
    wait = [index(a, WAIT) for a in fetch_agents]
    t_layout, f_layout = team.turtlebot_layout, team.fetch_layout
    carried, location = t_layout["carried"], t_layout["location"]
    staged, waiting = f_layout["staged"], f_layout["waiting"]
    at_desk = [team.location("desk", home[w]) for w in team.turtlebot_ids]
    # The policy's memory: per Fetch, the tools it has found so far, and the desk count when
    # its last search started (-1: its last option was no search).
    found = [0] * team.fetches
    before = [-1] * team.fetches

    def ready(point: DecisionView, joint: np.ndarray, f: int) -> list[int]:
        """Turtlebots a pass of Fetch ``f`` reaches now: its own ``waiting`` bits, and those of
        its Turtlebots that stand at its desk and re-choose GetTool at this point."""
        bits = point.vectors[fetch_agents[f]][waiting]
        return [
            w
            for w in team.turtlebot_ids
            if bits[w] > 0
            or (
                point.choosing[w]
                and home[w] == f
                and joint[w] == get_tool[w]
                and point.vectors[w][location][at_desk[w]] > 0
            )
        ]

    def act(point: DecisionView) -> np.ndarray:
        if point.ticks == 0:
            found[:], before[:] = [0] * team.fetches, [-1] * team.fetches
        joint = point.running.copy()
        for w in team.turtlebot_ids:
            tools = np.flatnonzero(point.vectors[w][carried])
            joint[w] = go_ws[w][team.owner(int(tools[0]))] if tools.size else get_tool[w]
        idle = []
        for f, a in enumerate(fetch_agents):
            if not point.choosing[a]:
                continue
            desk = point.vectors[a][staged]  # one-hot: none, one, two or more tools staged
            count = int(np.argmax(desk))
            if before[f] >= 0 and count > before[f]:
                found[f] += 1  # the last search staged its tool
            before[f] = -1
            waiting_now = ready(point, joint, f)
            if desk[0] == 0 and waiting_now:
                joint[a] = passes[f][waiting_now[0]]
            elif found[f] < len(order[f]) and desk[-1] == 0:  # a tool left, desk not full
                joint[a] = searches[f][found[f]]
                before[f] = count
            else:
                idle.append(f)
        active = any(point.choosing[a] and f not in idle for f, a in enumerate(fetch_agents))
        sync = bool(point.choosing.all()) and point.ticks > 0
        for f in idle:
            a = fetch_agents[f]
            no_op = sync and active and found[f] > 0  # its first tool is found: finds nothing
            no_op = no_op and point.available[a][searches[f][0]]  # masked: it cannot find one
            joint[a] = searches[f][0] if no_op else wait[f]
        return joint

    return act
