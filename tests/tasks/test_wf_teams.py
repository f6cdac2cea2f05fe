"""Water Filling at other team sizes: names, option sets and observations per jar, the tiled
room, fills by several vehicles, the scripted policy's split of the jars, cameras for choosing
robots only, and the settings' checks. Short episodes: the default task is covered in
``test_water_filling.py``, the contract at a bigger size in ``test_contract.py``."""

from __future__ import annotations

# isort: off
import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
# isort: on

import hashlib

import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.options.base import Execution
from maopg.sim.planning import RELAXATION_CELLS, dijkstra_cost_to_go, relaxed_cost_to_go
from maopg.tasks import load, make_config
from maopg.tasks.panel import Field, Gauge
from maopg.tasks.water_filling.display import panel
from maopg.tasks.water_filling.scene import arena_path, arena_source, read_arena
from maopg.tasks.water_filling.scripted import split_jars

SIZES = [(1, 1, 3), (2, 1, 4), (4, 4, 8)]
"""(vehicles, drones, jars): the default team, a small and a big one."""
MAX_TICKS = 40


def settings(size: tuple[int, int, int], **more) -> dict:
    return dict(zip(("vehicles", "drones", "jars"), size, strict=True), **more)


def names(kind: str, count: int) -> list[str]:
    return [kind] if count == 1 else [f"{kind}{k}" for k in range(count)]


@pytest.mark.parametrize("size", SIZES, ids=str)
def test_agents_options_and_observations_follow_the_team(size) -> None:
    vehicles, drones, jars = size
    env = make_env("water_filling", "continue", overrides=settings(size, max_ticks=MAX_TICKS))
    try:
        spec, task = env.spec, env.task
        assert list(spec.agent_names) == names("vehicle", vehicles) + names("drone", drones)
        assert spec.option_counts == (4 + 3 * jars,) * vehicles + (4 + jars,) * drones
        per_jar = [f"{kind}({c})" for kind in ("Fill", "NavTo", "NavToFill") for c in range(jars)]
        assert spec.agents[0].option_names == ("Up", "Down", "Left", "Right", *per_jar)
        assert spec.agents[-1].option_names[4:] == tuple(f"NavTo({c})" for c in range(jars))
        for agent in spec.agents:
            assert agent.layout.fields == (
                ("known_levels", jars),
                ("elapsed", jars),
                ("position", 2),
            )
        assert len(task.jars) == len(task.water.levels) == jars
        starts = [task.planar_position(a) for a in range(spec.num_agents)]
        assert len(set(starts)) == len(starts), "every robot starts on its own spot"
        point = env.reset(seed=0)
        assert all(np.all(np.abs(v[-2:]) <= 1.0) for v in point.vectors)  # inside the room
    finally:
        env.close()


def test_the_default_team_plays_in_the_arena_file_and_bigger_ones_in_tiled_rooms() -> None:
    config = make_config("water_filling")
    arena = read_arena(config)
    assert arena.tiles == (1, 1) and arena_source(config, arena.tiles) == arena_path(config)
    for size, tiles in (((2, 1, 4), (2, 1)), ((4, 4, 8), (2, 2)), ((1, 1, 7), (3, 1))):
        arena = read_arena(make_config("water_filling", settings(size)))
        assert arena.tiles == tiles
        assert arena.half_extent == (5.0 * tiles[0], 5.0 * tiles[1])
        assert len({tuple(site) for site in arena.jar_sites}) == size[2]  # own stands
        xy = np.abs(arena.jar_xy)
        assert np.all(xy < np.array(arena.half_extent) - 0.5), "every jar inside the walls"


def test_the_tiled_room_encloses_reachable_jars() -> None:
    task = load("water_filling", settings((4, 4, 8)))
    try:
        model = task.scene.model
        assert tuple(model.geom("floor").size[:2]) == (10.0, 10.0)
        assert model.geom("wall_n").pos[1] == pytest.approx(10.05)
        assert model.geom("wall_e").size[1] == pytest.approx(10.0)
        for c, handle in enumerate(task.jars):  # the jar props stand on the layout's sites
            body = model.geom_bodyid[handle.geom_id]
            assert np.allclose(task.scene.data.xpos[body][:2], task.jar_xy[c])
        config = task.config
        for agent, planner in enumerate(task.planners):  # every jar reachable from every start
            start = planner.grid.cell(task.planar_position(agent))
            reach = config.drone_standoff if task.team.is_drone(agent) else config.vehicle_reach
            for c in range(len(task.jars)):
                field = planner.field(task.jar_xy[c], reach)
                assert np.isfinite(field[start]), (agent, c)
    finally:
        task.close()


def test_both_cost_to_go_methods_give_the_same_field_in_a_tiled_room() -> None:
    task = load("water_filling", settings((2, 1, 4)))
    try:
        grid = task.planners[0].grid
        assert grid.blocked.size > RELAXATION_CELLS  # the task used Dijkstra
        ny, nx = grid.blocked.shape
        xs = grid.origin[0] + grid.resolution * np.arange(nx)
        ys = grid.origin[1] + grid.resolution * np.arange(ny)
        goal = task.jar_xy[3]
        seeds = np.hypot(xs[None, :] - goal[0], ys[:, None] - goal[1]) <= 0.8
        relaxed = relaxed_cost_to_go(grid.blocked, seeds)
        assert np.isfinite(relaxed).sum() > grid.blocked.size / 2
        assert np.array_equal(relaxed, dijkstra_cost_to_go(grid.blocked, seeds))
    finally:
        task.close()


def test_a_second_vehicle_navigates_and_two_vehicles_fill_on_one_tick() -> None:
    task = load("water_filling", settings((2, 1, 4)))
    try:
        task.reset(0)
        jar = 1  # in the east room, where vehicle1 starts
        option = next(o for o in task.options(1) if o.name == f"NavToFill({jar})")
        ex = Execution(option, 1, 0)
        option.start(task, ex)
        task.set_levels([0.5, 0.5, 0.5, 0.5])
        while True:
            option.step(task, ex)
            for other in (0, 2):
                task.hold(other)
            task.tick()
            ex.ticks += 1
            if option.done(task, ex):
                break
            assert ex.ticks < 60
        assert task.facing(1, jar) and task.distance_to_jar(1, jar) <= 1.0
        assert task.water.levels[jar] == 1.0 and task.fills == 1
        # Both vehicles ask on the same tick: each fill is applied by the rule, in agent order.
        task.set_levels([0.5, 0.5, 0.5, 0.5])
        task.request_fill(1, jar)
        task.request_fill(0, 0)  # far from vehicle0: refused
        task.tick()
        assert task.water.levels[jar] == 1.0 and task.water.levels[0] < 1.0
        assert task.fills == 2
    finally:
        task.close()


@pytest.mark.parametrize("strategy", ["continue", "any", "all"])
@pytest.mark.parametrize("size", SIZES, ids=str)
def test_the_scripted_policy_plays_every_size_under_every_strategy(size, strategy) -> None:
    env = make_env("water_filling", strategy, overrides=settings(size, max_ticks=MAX_TICKS))
    seen = []
    try:
        result = run_episode(env, reference_policy("scripted", env), seed=1, on_step=seen.append)
    finally:
        env.close()
    assert result.ticks == MAX_TICKS and seen[-1].truncated
    assert sum(result.rewards) == pytest.approx(result.ret)
    fill_or_look = [n.startswith("NavTo") for n in env.spec.agents[0].option_names]
    assert all(fill_or_look[o] for o in seen[1].running[: size[0]]), "vehicles NavToFill"


def test_the_scripted_policy_splits_the_jars() -> None:
    starts = np.array([[0.0, 0.0], [10.0, 0.0]])
    jars = np.array([[1.0, 0.0], [9.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    shares = split_jars(starts, jars)
    assert [s.tolist() for s in shares] == [[0, 2], [1, 3]]  # in turns: 1 is far from 0's
    three = split_jars(np.array([[0.0, 0.0], [0.5, 0.0], [10.0, 0.0]]), jars)
    assert [s.tolist() for s in three] == [[0, 3], [2], [1]]  # shares differ by one at most
    assert [s.tolist() for s in split_jars(starts[:1], jars)] == [[0, 1, 2, 3]]  # one: all
    assert [s.tolist() for s in split_jars(starts, jars[:1])] == [[0], [0]]  # none left: all
    env = make_env("water_filling", overrides=settings((4, 4, 8)))
    try:
        point = env.reset(seed=0)
        joint = reference_policy("scripted", env)(point)
    finally:
        env.close()
    assert len(set(joint[:4].tolist())) == 4 and len(set(joint[4:].tolist())) == 4


def test_the_same_seed_gives_the_same_trajectory_in_a_big_team() -> None:
    def trajectory() -> str:
        env = make_env("water_filling", "continue", overrides=settings((4, 4, 8), max_ticks=25))
        digest = hashlib.sha256()
        env.add_tick_listener(lambda e, r: digest.update(e.task.scene.data.qpos.tobytes()))
        try:
            result = run_episode(env, RandomPolicy(env.spec, 2), seed=3)
        finally:
            env.close()
        digest.update(np.array(result.rewards).tobytes())
        return digest.hexdigest()

    assert trajectory() == trajectory()


def test_cameras_render_only_the_robots_that_choose(monkeypatch) -> None:
    env = make_env(
        "water_filling", "continue", images=True, image_size=16, overrides=settings((2, 1, 4))
    )
    rendered = []
    render = env.task.render
    monkeypatch.setattr(
        env.task, "render", lambda agents, out: rendered.append(list(agents)) or render(agents, out)
    )
    points = []
    try:
        run_episode(env, RandomPolicy(env.spec, 0), seed=0, on_step=points.append)
    finally:
        env.close()
    choosing = [np.flatnonzero(p.choosing).tolist() for p in points if not p.done]
    assert rendered[: len(choosing)] == choosing
    assert any(len(c) < 3 for c in choosing), "some decision points let robots continue"


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"vehicles": 0}, r"env.vehicles must be >= 1, got 0"),
        ({"drones": -1}, r"env.drones must be >= 1, got -1"),
        ({"jars": 0}, r"env.jars must be >= 1, got 0"),
        (
            {"vehicles": 2, "vehicle_start": (0.0, 0.0)},
            r"vehicle_start sets the start of the only vehicle; with vehicles=2",
        ),
        ({"drones": 3, "drone_start": (1.0, 1.0)}, r"drone_start .* with drones=3"),
    ],
)
def test_impossible_team_settings_are_refused_by_name(overrides, message) -> None:
    with pytest.raises(ValueError, match=message):
        make_env("water_filling", overrides=overrides)


def test_the_command_line_names_a_bad_team_setting_in_one_line(capsys) -> None:
    from maopg.experiment.cli.eval_cli import main

    argv = ["evaluate", "--reference", "random", "--task", "water_filling", "--episodes", "1"]
    assert main([*argv, "env.jars=0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"{err[0].split(':')[0]}: error: env.jars must be >= 1, got 0"]


def test_one_start_setting_still_moves_the_only_robot_of_its_kind() -> None:
    arena = read_arena(make_config("water_filling", {"vehicles": 3, "drone_start": (1.0, -1.0)}))
    assert arena.starts[-1] == (1.0, -1.0) and len(arena.starts) == 4


def test_the_panel_has_a_bar_per_jar() -> None:
    state = {
        "levels": [0.5] * 8,
        "known_levels": [1.0] * 8,
        "elapsed": list(range(8)),
        "fills": 3,
    }
    items = panel(state)
    gauges = [item for item in items if isinstance(item, Gauge)]
    assert [g.name for g in gauges] == [f"jar {c}" for c in range(8)]
    assert all(g.fraction == 0.5 and g.mark == 1.0 for g in gauges)
    assert gauges[7].text == "0.50, seen 7 ago" and items[-1] == Field("fills", "3")
