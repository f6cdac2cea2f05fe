"""Water Filling task: water dynamics, fill and knowledge rules, reward, navigation options in
real physics, camera views of the levels, reference policies and every strategy."""

from __future__ import annotations

# isort: off
import maopg  # noqa: F401  (sets MUJOCO_GL=egl before mujoco is imported)
# isort: on

import math

import numpy as np
import pytest

from maopg.env import make_env
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.options.base import Execution
from maopg.sim.planning import GridPlanner, path_length
from maopg.tasks import load
from maopg.tasks.water_filling.config import Config
from maopg.tasks.water_filling.constants import DRONE, NUM_JARS, OBS, VEHICLE
from maopg.tasks.water_filling.options import option_sets
from maopg.tasks.water_filling.scene import read_arena
from maopg.tasks.water_filling.task import WaterFilling
from maopg.tasks.water_filling.water import WaterLevels, jar_reward

JAR_XY = read_arena(Config()).jar_xy  # read from the arena's sites
SPAWNS = ((-0.4, -0.3), (0.6, 0.4), (0.5, -0.6))  # the arena's two spawn sites and one more
_NAMES = [[o.name for o in opts] for opts in option_sets(Config())]


def option(agent: int, name: str) -> int:
    """Id of an option of the default (non-primitive) task."""
    return _NAMES[agent].index(name)


NAV_TO_VEHICLE, NAV_TO_FILL = option(VEHICLE, "NavTo(0)"), option(VEHICLE, "NavToFill(0)")
NAV_TO_DRONE = option(DRONE, "NavTo(0)")
FILL = option(VEHICLE, "Fill(0)")
KNOWN, ELAPSED = OBS["known_levels"], OBS["elapsed"]


# ---------------------------------------------------------------------------- water dynamics
def test_level_sequence_is_reproducible_per_seed_and_stays_in_unit_interval() -> None:
    def sequence(seed: int) -> np.ndarray:
        water = WaterLevels(Config())
        water.reset(seed)
        out = []
        for _ in range(400):
            water.step()
            out.append(water.levels.copy())
        return np.array(out)

    a, b, c = sequence(3), sequence(3), sequence(4)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert a.min() >= 0.0 and a.max() <= 1.0
    assert (a == 0.0).any(), "levels drop fast: some jar runs dry within 400 ticks"
    assert np.all(np.diff(a, axis=0) <= 0.0), "without fills levels only fall"


def test_drop_statistics_follow_the_design_rule() -> None:
    """Intervals round(Exp(scale ~ U{5..14})) ticks, drops |N(interval/500, 0.2)|: compare the
    simulated mean gap between drops and mean drop with a Monte Carlo of the rule itself."""
    water = WaterLevels(Config())
    water.reset(0)
    drops, drop_ticks = [], []
    for t in range(30_000):
        water.step()
        for jar in range(NUM_JARS):
            if water.levels[jar] < 1.0:
                drops.append(1.0 - water.levels[jar])
                drop_ticks.append((jar, t))
                water.fill(jar)
    gaps = np.concatenate(
        [np.diff([t for j, t in drop_ticks if j == jar]) for jar in range(NUM_JARS)]
    )
    rng = np.random.default_rng(123)
    intervals = np.round(rng.exponential(rng.integers(5, 15, 200_000))).astype(int)
    expected_gap = np.maximum(intervals, 1).mean()  # an interval of 0 expires the next tick
    expected_drop = np.minimum(np.abs(rng.normal(intervals / 500.0, 0.2)), 1.0).mean()
    assert np.mean(gaps) == pytest.approx(expected_gap, rel=0.06)
    assert np.mean(drops) == pytest.approx(expected_drop, rel=0.05)


def test_reward_is_paper_eq6_on_the_true_levels() -> None:
    assert jar_reward([1.0, 1.0, 1.0]) == pytest.approx(3 * (1 - 1 / 1.001))
    assert jar_reward([1.0, 0.5, 0.0]) == pytest.approx(
        (1 - 1 / 1.001) + (1 - 1 / 0.501) + (1 - 1 / 0.001)
    )
    task = load("water_filling")
    task.reset(5)
    task.set_levels([0.7, 0.3, 0.05])
    for _ in range(10):
        for i in (VEHICLE, DRONE):
            task.hold(i)
        reward = task.tick()
        w = task.water.levels
        assert reward == pytest.approx(sum(1.0 - 1.0 / (x + 0.001) for x in w))
    task.close()


def _vehicle_near(jar: int, distance: float) -> WaterFilling:
    """A task whose vehicle starts ``distance`` m from ``jar``, on the room side of it."""
    toward_centre = -JAR_XY[jar] / np.linalg.norm(JAR_XY[jar])
    start = JAR_XY[jar] + distance * toward_centre
    task = load("water_filling", {"vehicle_start": tuple(start)})
    task.reset(0)
    return task


def test_fill_resets_to_full_only_within_one_metre() -> None:
    near, far = _vehicle_near(2, 0.9), _vehicle_near(2, 1.15)
    fill = near.options(VEHICLE)[FILL + 2]
    assert fill.name == "Fill(2)"
    assert fill.available(near, VEHICLE) and not fill.available(far, VEHICLE)
    assert not near.options(VEHICLE)[FILL].available(near, VEHICLE)  # Fill(0): far away
    for task, expect_full in ((near, True), (far, False)):
        task.set_levels([0.5, 0.5, 0.2])
        ex = Execution(fill, VEHICLE, 0)
        fill.start(task, ex)
        fill.step(task, ex)  # the far one asks too: the rule, not the mask, must refuse
        task.drone.hold()
        task.tick()
        assert bool(task.water.levels[2] == 1.0) is expect_full
        assert task.water.levels[0] == task.water.levels[1] == 0.5  # no drop on tick 1 here
        assert task.fills == int(expect_full)
        task.close()


# ---------------------------------------------------------------------------- knowledge rule
def test_known_levels_change_only_when_a_robot_is_within_one_metre() -> None:
    """Primitive mode (every tick a decision point): the vehicle wanders near jar 2."""
    toward_centre = -JAR_XY[2] / np.linalg.norm(JAR_XY[2])
    start = tuple(JAR_XY[2] + 0.9 * toward_centre)
    env = make_env("water_filling", "primitive", overrides={"vehicle_start": start})
    rng = np.random.default_rng(0)
    point = env.reset(seed=2)
    max_ticks = env.spec.max_ticks
    seen = unseen = 0
    prev_known = point.vectors[VEHICLE][KNOWN].copy()
    prev_elapsed = point.vectors[VEHICLE][ELAPSED] * max_ticks
    vehicle, drone = env.spec.agents
    left, right, fill = (vehicle.option_index(n) for n in ("Left", "Right", "Fill"))
    drone_moves = [drone.option_index(n) for n in ("Up", "Down", "Left", "Right")]
    for _ in range(120):
        # vehicle: Left/Right (toward / away from the room centre) or Fill; drone: random
        moves = [left, right, fill] if point.available[VEHICLE][fill] else [left, right]
        joint = np.array([rng.choice(moves), 0])
        joint[DRONE] = drone_moves[rng.integers(4)]
        point = env.step(joint)
        task = point.info["task"]
        obs = point.vectors[VEHICLE]
        known, elapsed = obs[KNOWN], obs[ELAPSED] * max_ticks
        for field in (KNOWN, ELAPSED):  # the knowledge is shared
            assert np.allclose(point.vectors[DRONE][field], obs[field])
        robots = [np.array(task["vehicle_xy"]), np.array(task["drone_xyz"][:2])]
        for jar in range(NUM_JARS):
            near = min(np.linalg.norm(r - JAR_XY[jar]) for r in robots) <= 1.0
            if near:
                seen += 1
                assert known[jar] == pytest.approx(task["levels"][jar])
                assert elapsed[jar] == pytest.approx(0.0, abs=1e-4)
            else:
                unseen += 1
                assert known[jar] == prev_known[jar]
                assert elapsed[jar] == pytest.approx(prev_elapsed[jar] + 1, abs=1e-3)
        prev_known, prev_elapsed = known.copy(), elapsed.copy()
    assert seen >= 20 and unseen >= 200, (seen, unseen)
    env.close()


# ---------------------------------------------------------------------------- navigation
def _robot_contacts(task: WaterFilling) -> list[str]:
    """Contacts of either robot's geoms with anything (walls, furniture, stands, floor)."""
    model, data = task.scene.model, task.scene.data
    roots = {r.root_body_id for r in task.agent_robots}
    hits = []
    for c in data.contact[: data.ncon]:
        g1, g2 = int(c.geom1), int(c.geom2)
        if {model.body_rootid[model.geom_bodyid[g]] for g in (g1, g2)} & roots:
            hits.append(f"{model.geom(g1).name} x {model.geom(g2).name}")
    return hits


def _run_options(task: WaterFilling, options: dict[int, int], limit: int = 80) -> dict[int, int]:
    """Run each agent's option to its end at the task level (finished agents hold); the
    number of ticks each took. Fails on any contact of a robot with the scene."""
    running = {}
    for agent, oid in options.items():
        option = task.options(agent)[oid]
        ex = Execution(option, agent, task.ticks)
        option.start(task, ex)
        running[agent] = ex
    ended = {}
    while running:
        for agent in (VEHICLE, DRONE):
            ex = running.get(agent)
            if ex is None:
                task.hold(agent)
            else:
                ex.option.step(task, ex)
        task.tick()
        assert not _robot_contacts(task), _robot_contacts(task)
        for agent, ex in list(running.items()):
            ex.ticks += 1
            if ex.option.done(task, ex):
                ended[agent] = ex.ticks
                del running[agent]
        assert task.ticks <= limit, f"options {options} still running: {running}"
    return ended


@pytest.mark.parametrize("spawn", SPAWNS)
def test_nav_to_reaches_every_jar_from_every_spawn_in_time_without_collisions(spawn) -> None:
    task = load("water_filling", {"vehicle_start": spawn, "drone_start": spawn})
    for jar in range(NUM_JARS):
        task.reset(jar)
        ids = {VEHICLE: NAV_TO_VEHICLE + jar, DRONE: NAV_TO_DRONE + jar}
        assert all(task.options(a)[o].name == f"NavTo({jar})" for a, o in ids.items())
        ended = _run_options(task, ids)
        for agent in (VEHICLE, DRONE):
            assert task.distance_to_jar(agent, jar) <= 1.0
            assert task.facing(agent, jar)
            # the time its speed allows along the shortest path (an independent A* plan)
            ref = GridPlanner(task.planners[agent].grid)
            length = path_length(spawn, ref.plan(spawn, JAR_XY[jar]))
            bound = math.ceil(length / task.step_length(agent)) + 6
            assert ended[agent] <= bound, (agent, jar, ended[agent], bound)
        assert task.updated[jar] == task.ticks  # its level is observed
        assert ended[DRONE] < ended[VEHICLE], ended  # durations follow from speed
    task.close()


def test_one_tick_moves_and_walls_stop_the_vehicle() -> None:
    env = make_env("water_filling", "continue")
    task = env.task
    env.reset(seed=0)
    x0, y0 = task.planar_position(VEHICLE)
    d0 = task.planar_position(DRONE)
    right_up = [option(VEHICLE, "Right"), option(DRONE, "Up")]
    point = env.step(right_up)  # both one tick
    assert point.duration == 1 and point.choosing.all()
    x1, y1 = task.planar_position(VEHICLE)
    # from rest the velocity servo's 0.1 s lag costs ~0.05 m; the next tick is a full 0.25 m
    assert 0.17 < x1 - x0 <= 0.26 and abs(y1 - y0) < 0.01
    env.step(right_up)
    assert task.planar_position(VEHICLE)[0] - x1 == pytest.approx(0.25, abs=0.02)
    assert task.planar_position(DRONE)[1] - d0[1] > 0.5  # accelerating north: 1 m/tick cruise
    for _ in range(30):  # 7.5 m of Left moves from x ~ -0.15: the west wall stops it
        point = env.step([option(VEHICLE, "Left"), option(DRONE, "Down")])
    x, _ = task.planar_position(VEHICLE)
    assert -4.8 < x < -4.6, x
    assert any("wall_w" in c for c in _robot_contacts(task))  # pressed against it, no tunnelling
    assert abs(task.drone.position[2] - task.config.cruise_altitude) < 0.1
    env.close()


# ---------------------------------------------------------------------------- images
def test_jar_level_is_visible_in_both_cameras_after_nav_to() -> None:
    task = load("water_filling", {"images": True})
    task.reset(0)
    jar = 1
    _run_options(task, {VEHICLE: NAV_TO_FILL + jar, DRONE: NAV_TO_DRONE + jar})
    assert task.water.levels[jar] == 1.0 and task.fills == 1  # NavToFill filled it
    frames = {}
    for level in (1.0, 0.2):
        task.set_levels([1.0, level, 1.0])
        out = np.zeros((2, 64, 64, 3), np.uint8)
        task.render([VEHICLE, DRONE], out)
        frames[level] = out.astype(int)
    for agent in (VEHICLE, DRONE):
        changed = np.abs(frames[1.0][agent] - frames[0.2][agent]).sum(axis=-1) > 60
        assert changed.sum() >= 15, (agent, int(changed.sum()))
    task.close()


# ---------------------------------------------------------------------------- policies, strategies
def test_scripted_beats_random_by_a_clear_margin_over_ten_seeds() -> None:
    env = make_env("water_filling", "continue", seed=0)
    scripted = [run_episode(env, reference_policy("scripted", env), seed=s).ret for s in range(10)]
    random = [run_episode(env, RandomPolicy(env.spec, s), seed=s).ret for s in range(10)]
    env.close()
    s_mean, r_mean = np.mean(scripted), np.mean(random)
    stderr = math.sqrt(np.var(scripted) / 10 + np.var(random) / 10)
    assert s_mean - r_mean > 3.0 * stderr, (s_mean, r_mean, stderr)
    assert s_mean > 0.8 * r_mean, "scripted keeps jars from running dry markedly longer"


@pytest.mark.parametrize("strategy", ["continue", "any", "all", "primitive"])
def test_every_strategy_runs_an_episode(strategy: str) -> None:
    env = make_env("water_filling", strategy, images=strategy == "any", overrides={"max_ticks": 60})
    counts = (5, 4) if strategy == "primitive" else (13, 7)
    assert env.spec.option_counts == counts
    assert env.spec.agents[VEHICLE].vector_size == 8
    policy = RandomPolicy(env.spec, 1)
    seen = []
    result = run_episode(env, policy, seed=1, on_step=seen.append)
    assert result.ticks == 60 and seen[-1].truncated and not seen[-1].terminated
    assert sum(result.rewards) == pytest.approx(result.ret)
    assert all(p.duration == 1 for p in seen[1:]) == (strategy == "primitive")
    if strategy == "any":
        assert seen[-1].images.shape == (2, 64, 64, 3) and seen[-1].images.std() > 5
    for p in seen:
        fields = OBS.split(p.vectors[VEHICLE])
        knowledge = np.concatenate([fields["known_levels"], fields["elapsed"]])
        assert np.all((knowledge >= 0) & (knowledge <= 1))
        assert np.all(np.abs(fields["position"]) <= 1)
    env.close()


def test_bad_option_ids_raise_value_errors_naming_the_agent() -> None:
    env = make_env("water_filling", "continue")
    point = env.reset(seed=0)
    assert not point.available[VEHICLE][FILL]  # no jar within 1 m of the spawn
    with pytest.raises(ValueError, match=r"'vehicle'.*out of range"):
        env.step([13, 0])
    with pytest.raises(ValueError, match=r"'drone'.*out of range"):
        env.step([0, 7])
    with pytest.raises(ValueError, match=r"Fill\(0\).*'vehicle'.*not available"):
        env.step([FILL, 0])
    with pytest.raises(ValueError, match="'drone' must choose"):
        env.step([0, -1])
    with pytest.raises(ValueError, match=r"unknown setting 'env\.jugs'"):
        make_env("water_filling", overrides={"jugs": 4})
    env.close()
