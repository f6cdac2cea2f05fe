"""Box Pushing (MuJoCo) with each ground robot: does one robot fail to move the big box where
two deliver it, at the settings given for that robot?

Run: ``.venv/bin/python bench/analysis/box_pushing_robots.py [ROBOT[:key=value,...] ...]``
(default: each built-in ground robot at its settings, ``ROBOT_SETTINGS`` in
``maopg/tasks/box_pushing/config.py``).
Prints a Markdown table.

The task's box masses and stall distance are sized for the Turtlebot's drive (180 N, 0.6 m/s).
A robot that pushes harder or softer, faster or slower needs its own: ``big_box_mass`` between
what one of it cannot move and what two can, and a ``stall_distance`` below the progress a
tick of its pushing makes. For each case, on the 6x6 arena: both robots drive to the waypoints
below the big box and push once together (delivered? in how many ticks?); then, afresh, one
robot pushes the big box alone, push after push, for 40 ticks (delivered? how far it moved);
then one robot pushes small box 0 (delivered?).
"""

from __future__ import annotations

import argparse

import numpy as np

from maopg.env import DecisionPoint, OptionEnv, make_env
from maopg.experiment.run.sysinfo import markdown
from maopg.tasks import make_config
from maopg.tasks.box_pushing.config import ROBOT_SETTINGS
from maopg.tasks.box_pushing.scene import BOXES

LONE_TICKS = 40
"""Ticks one robot pushes the big box alone."""


def choose(env: OptionEnv, point: DecisionPoint, **chosen: str) -> DecisionPoint:
    """Step with the named agents' options (by name), every other choosing agent staying."""
    joint = point.running.copy()
    for i, agent in enumerate(env.spec.agents):
        if point.choosing[i]:
            joint[i] = agent.option_index(chosen.get(agent.name, "Stay"))
    return env.step(joint)


def until_done(env: OptionEnv, point: DecisionPoint, **chosen: str) -> DecisionPoint:
    """The named agents run these options to their ends (the others stay)."""
    point = choose(env, point, **chosen)
    while not point.done and not all(point.choosing[env.task.agent_names.index(a)] for a in chosen):
        point = choose(env, point)
    return point


BIG_BOX_AHEAD = "01000"
"""An agent's observation bits facing the big box from its waypoint below it."""


def below_the_big_box(env: OptionEnv) -> DecisionPoint:
    """Both robots at their waypoints below the big box, facing it, both choosing; a
    ``RuntimeError`` where the navigation does not get them there."""
    point = until_done(env, env.reset(), agent0="GoToBigBox(left)", agent1="GoToBigBox(right)")
    while not point.choosing.all():
        point = choose(env, point)
    seen = ["".join(str(int(b)) for b in v) for v in point.vectors]
    if seen != [BIG_BOX_AHEAD] * 2:
        raise RuntimeError(f"the robots did not reach the big box (they see {seen})")
    return point


def box_at(env: OptionEnv, box: int) -> np.ndarray:
    scene = env.task.scene
    return scene.data.xpos[scene.model.body(BOXES[box]).id, :2].copy()


def delivered(env: OptionEnv, box: str) -> str:
    return "delivered" if box in env.task.describe()["delivered"] else "not delivered"


def measure(robot: str, settings: dict) -> list[str]:
    """One table row (module docstring)."""
    overrides = {"turtlebot_robot": robot, "max_ticks": 200, **settings}
    env = make_env("box_pushing", "continue", seed=0, overrides=overrides)
    try:
        point = below_the_big_box(env)
        pushed = until_done(env, point, agent0="Push", agent1="Push")
        two = f"{delivered(env, 'big box')} ({pushed.ticks - point.ticks} ticks)"
        point = below_the_big_box(env)
        start, first = box_at(env, 2), point.ticks
        while point.ticks < first + LONE_TICKS and not point.done:
            point = until_done(env, point, agent0="Push")
        alone = delivered(env, "big box")
        moved = float(np.linalg.norm(box_at(env, 2) - start))
        point = until_done(env, env.reset(), agent0="GoToSmallBox(0)")
        until_done(env, point, agent0="Push")
        small = delivered(env, "small box 0")
    finally:
        env.close()
    shown = ", ".join(f"{k}={v}" for k, v in settings.items()) or "defaults"
    return [robot, shown, two, f"{alone}, moved {moved:.3f} m", small]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("cases", nargs="*", help="ROBOT or ROBOT:key=value,... (default: all)")
    args = parser.parse_args()
    cases = [(robot, dict(settings)) for robot, settings in ROBOT_SETTINGS.items()]
    if args.cases:
        cases = []
        for case in args.cases:
            robot, _, given = case.partition(":")
            items = [item for item in given.split(",") if item]
            if any("=" not in item for item in items):
                parser.error(f"{case!r}: write ROBOT or ROBOT:key=value,key=value")
            pairs = (item.split("=", 1) for item in items)
            cases.append((robot, {k: int(v) if v.isdigit() else float(v) for k, v in pairs}))
    for robot, settings in cases:  # a bad robot or setting: one line, before any output
        try:
            make_config("box_pushing", {"turtlebot_robot": robot, **settings})
        except (KeyError, ValueError) as error:
            parser.error(str(error).strip("'\""))
    print("### Box Pushing with each ground robot (`bench/analysis/box_pushing_robots.py`)\n")
    print(markdown())
    print(
        f"\n6x6 arena; two robots push the big box once together; one pushes it alone for "
        f"{LONE_TICKS} ticks; one pushes small box 0.\n"
    )
    print("| robot | settings | two robots, big box | one robot, big box | one robot, small box |")
    print("|---|---|---|---|---|")
    for robot, settings in cases:
        print("| " + " | ".join(measure(robot, settings)) + " |", flush=True)


if __name__ == "__main__":
    main()
