"""The hand-written Water Filling policy: the reference level of the learning curves."""

from __future__ import annotations

import numpy as np

from maopg.sim.robots import get_robot
from maopg.tasks.scripting import DecisionView, ScriptedPolicy, option_finder
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import nav_to, nav_to_fill, obs_layout
from maopg.tasks.water_filling.options import option_sets
from maopg.tasks.water_filling.scene import read_arena
from maopg.tasks.water_filling.team import Team

EXPECTED_DROP_PER_TICK = 0.017
"""Expected level drop per tick under the default dynamics: E|N(~0.02, 0.2)| ~ 0.16 every
E[interval] ~ 9.5 ticks. The policy uses it to age what it knows."""
DETOUR = 1.3
"""Straight-line travel is padded by 30 % for the detours around furniture."""


def scripted_policy(config: Config) -> ScriptedPolicy:
    """A reference policy that reads only the agents' observation vectors.

    Drones: patrol — fly to the jar whose level is stalest and so refresh the shared knowledge.
    Vehicles: NavToFill the jar expected to be lowest when it gets there: last-known level minus
    the expected drop over (ticks since observed + travel ticks at full speed along the straight
    line, padded for detours).

    A team splits the jars once (:func:`split_jars`): each robot looks only among its own share,
    jars near its start, so the robots of a kind spread over the room instead of all
    chasing the jar that looks worst. With one robot of a kind its share is every jar, and the
    policy is the one-vehicle, one-drone policy it always was.
    """
    if config.primitive:
        raise ValueError("the scripted Water Filling policy drives options, not primitive actions")
    team = Team.of(config)
    arena = read_arena(config)
    jars, half_extent = arena.jar_xy, np.array(arena.half_extent)
    index = option_finder(option_sets(config), team.names)
    vehicles, drones = range(team.vehicles), team.drone_agents
    starts = np.array(arena.starts)
    share = {
        **dict(zip(vehicles, split_jars(starts[: team.vehicles], jars), strict=True)),
        **dict(zip(drones, split_jars(starts[team.vehicles :], jars), strict=True)),
    }
    # Every robot of a kind has the same option set: the ids of its kind's first robot.
    fill_at = np.array([index(vehicles[0], nav_to_fill(c)) for c in range(team.jars)])
    look_at = np.array([index(drones[0], nav_to(c)) for c in range(team.jars)])
    vehicle_speed = get_robot(config.vehicle_robot).resolve_constants().max_speed
    step = vehicle_speed * config.tick_seconds  # vehicle metres per tick
    layout = obs_layout(team.jars)
    known, elapsed, position = layout["known_levels"], layout["elapsed"], layout["position"]

    def act(point: DecisionView) -> np.ndarray:
        joint = point.running.copy()
        for agent in np.flatnonzero(point.choosing):
            obs, mine = point.vectors[agent], share[agent]
            if agent in vehicles:
                ago = obs[elapsed] * config.max_ticks
                xy = obs[position] * half_extent
                travel = DETOUR * np.hypot(*(jars[mine] - xy).T) / step
                expected = obs[known][mine] - EXPECTED_DROP_PER_TICK * (ago[mine] + travel)
                joint[agent] = fill_at[mine[int(np.argmin(expected))]]
            else:
                joint[agent] = look_at[mine[int(np.argmax(obs[elapsed][mine]))]]
        return joint

    return act


def split_jars(starts: np.ndarray, jars: np.ndarray) -> list[np.ndarray]:
    """Each robot's share of the jars (ascending jar ids): in rounds, each robot in turn takes
    the unclaimed jar nearest its start, so shares differ by at most one jar. A robot left
    without a jar (more robots than jars) shares them all."""
    distance = np.hypot(*(starts[:, None, :] - jars[None, :, :]).transpose(2, 0, 1))
    owner = np.full(len(jars), -1)
    for turn in range(len(jars)):
        robot = turn % len(starts)
        owner[np.argmin(np.where(owner < 0, distance[robot], np.inf))] = robot
    everything = np.arange(len(jars))
    return [
        mine if (mine := np.flatnonzero(owner == r)).size else everything
        for r in range(len(starts))
    ]
