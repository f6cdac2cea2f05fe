"""The hand-written Water Filling policy: the reference level of the learning curves."""

from __future__ import annotations

import numpy as np

from maopg.sim.robots import get_robot
from maopg.tasks.scripting import DecisionView, ScriptedPolicy, option_finder
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import (
    AGENTS,
    DRONE,
    NUM_JARS,
    OBS,
    VEHICLE,
    nav_to,
    nav_to_fill,
)
from maopg.tasks.water_filling.options import option_sets
from maopg.tasks.water_filling.scene import read_arena

EXPECTED_DROP_PER_TICK = 0.017
"""Expected level drop per tick under the default dynamics: E|N(~0.02, 0.2)| ~ 0.16 every
E[interval] ~ 9.5 ticks. The policy uses it to age what it knows."""
DETOUR = 1.3
"""Straight-line travel is padded by 30 % for the detours around furniture."""


def scripted_policy(config: Config) -> ScriptedPolicy:
    """A reference policy that reads only the agents' observation vectors.

    Drone: patrol — fly to the jar whose level is stalest and so refresh the shared knowledge.
    Vehicle: NavToFill the jar expected to be lowest when it gets there: last-known level minus
    the expected drop over (ticks since observed + travel ticks at full speed along the straight
    line, padded for detours).
    """
    if config.primitive:
        raise ValueError("the scripted Water Filling policy drives options, not primitive actions")
    arena = read_arena(config)
    jars, half_extent = arena.jar_xy, np.array(arena.half_extent)
    index = option_finder(option_sets(config), AGENTS)
    fill_at = [index(VEHICLE, nav_to_fill(c)) for c in range(NUM_JARS)]
    look_at = [index(DRONE, nav_to(c)) for c in range(NUM_JARS)]
    vehicle_speed = get_robot(config.vehicle_robot).resolve_constants().max_speed
    step = vehicle_speed * config.tick_seconds  # vehicle metres per tick
    known, elapsed, position = OBS["known_levels"], OBS["elapsed"], OBS["position"]

    def act(point: DecisionView) -> np.ndarray:
        joint = point.running.copy()
        if point.choosing[VEHICLE]:
            obs = point.vectors[VEHICLE]
            ago = obs[elapsed] * config.max_ticks
            travel = DETOUR * np.hypot(*(jars - obs[position] * half_extent).T) / step
            expected = obs[known] - EXPECTED_DROP_PER_TICK * (ago + travel)
            joint[VEHICLE] = fill_at[int(np.argmin(expected))]
        if point.choosing[DRONE]:
            joint[DRONE] = look_at[int(np.argmax(point.vectors[DRONE][elapsed]))]
        return joint

    return act
