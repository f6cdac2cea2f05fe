"""The option scheduler's contract, checked on real Tool Delivery episodes (real physics)."""

from __future__ import annotations

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

from maopg.env import DecisionPoint, OptionEnv, make_env
from maopg.env.pettingzoo import OptionParallelEnv
from maopg.env.rollout import RandomPolicy
from maopg.sim import robots
from maopg.sim.robots import ASSETS_DIR, register_robot
from maopg.sim.robots.vehicle import VehicleAdapter, VehicleConstants
from maopg.tasks.tool_delivery.constants import FETCH, TOOL_ROOM_WAIT, WORKSHOP

GAMMA = 0.95
# Option durations of the Fetch in ticks (docs/DESIGN.md §7); the Turtlebots' depend on distance.
FETCH_TICKS = {"Wait": 1, "PassTo(0)": 4, "PassTo(1)": 4}
FETCH_TICKS |= {f"SearchTool({j})": 6 for j in range(3)}
TARGETS = {"GoToWS": WORKSHOP, "GoToTR": TOOL_ROOM_WAIT}


class Recorder:
    """Records every tick between decision points through the env's tick listener."""

    def __init__(self, env: OptionEnv) -> None:
        self.rewards: list[float] = []
        self.positions: list[np.ndarray] = []
        self.ticks: list[int] = []
        env.add_tick_listener(self)

    def __call__(self, env: OptionEnv, reward: float) -> None:
        task = env.task
        self.rewards.append(reward)
        self.ticks.append(task.ticks)
        self.positions.append(np.array([r.position[:2] for r in task.turtlebots]))

    def take(self) -> tuple[list[float], list[np.ndarray], list[int]]:
        out = self.rewards, self.positions, self.ticks
        self.rewards, self.positions, self.ticks = [], [], []
        return out


def play(strategy: str, seed: int, episodes: int = 2):
    """Yield (previous point, joint option, next point, per-tick records) over random episodes."""
    env = make_env("tool_delivery", strategy, seed=seed, gamma=GAMMA)
    recorder = Recorder(env)
    policy = RandomPolicy(env.spec, seed)
    try:
        for _ in range(episodes):
            point = env.reset()
            recorder.take()
            while not point.done:
                joint = policy(point)
                nxt = env.step(joint)
                yield env, point, joint, nxt, recorder.take()
                point = nxt
    finally:
        env.close()


def option_name(env: OptionEnv, agent: int, option: int) -> str:
    return env.spec.agents[agent].option_names[option]


@pytest.mark.parametrize("seed", [0, 1])
def test_continue_never_interrupts_and_only_finished_agents_choose(seed: int) -> None:
    started = {}  # agent -> tick its current option started
    for env, point, joint, nxt, _ in play("continue", seed):
        for i in np.flatnonzero(point.choosing):
            started[i] = point.ticks
        assert np.array_equal(nxt.running, joint), "the executed joint option is reported"
        for i in range(env.num_agents):
            name = option_name(env, i, nxt.running[i])
            ran = nxt.ticks - started[i]
            ended = nxt.choosing[i]
            if i == FETCH:
                assert ended == (ran == FETCH_TICKS[name]) or nxt.done, (name, ran)
            elif name in TARGETS:
                at_target = env.task.turtlebots[i].at(TARGETS[name], 0.05)
                assert ended == at_target or nxt.done, (name, ran)
            if ended:
                assert ran >= 1


@pytest.mark.parametrize("seed", [0, 1])
def test_any_makes_everyone_choose_at_every_decision_point(seed: int) -> None:
    n_points = 0
    for _, _, _, nxt, _ in play("any", seed):
        if not nxt.done:
            assert nxt.choosing.all()
            n_points += 1
    assert n_points > 10


@pytest.mark.parametrize("seed", [0, 1])
def test_all_idles_finished_agents_until_everyone_finished(seed: int) -> None:
    for env, point, joint, nxt, (_, positions, _) in play("all", seed):
        assert point.choosing.all()
        if nxt.done:
            continue
        assert nxt.choosing.all()
        fetch = option_name(env, FETCH, joint[FETCH])
        assert nxt.duration >= FETCH_TICKS[fetch], "the Fetch's option was not cut short"
        for w in (0, 1):
            name = option_name(env, w, joint[w])
            if name in TARGETS:
                # After arriving, an idle Turtlebot holds its position until the sync.
                dist = [np.linalg.norm(p[w] - TARGETS[name]) for p in positions]
                arrived = [k for k, d in enumerate(dist) if d <= 0.05]
                assert arrived, f"{name} must end before the sync"
                assert all(d <= 0.05 for d in dist[arrived[0] :])


@pytest.mark.parametrize("strategy", ["continue", "all"])
def test_running_option_names_show_who_waits(strategy: str) -> None:
    """What the video captions show each tick: the executing option, or ``idle`` for an agent
    that finished and waits for the others (only under ``all``)."""
    env = make_env("tool_delivery", strategy, seed=0)
    names: list[tuple[str, ...]] = []
    env.add_tick_listener(lambda e, _reward: names.append(e.running_option_names()))
    policy = RandomPolicy(env.spec, 0)
    try:
        point = env.reset()
        assert env.running_option_names() == ("-",) * env.num_agents
        while not point.done:
            point = env.step(policy(point))
    finally:
        env.close()
    idle = sum(name == "idle" for tick in names for name in tick)
    known = {name for agent in env.spec.agents for name in agent.option_names}
    assert all(name in known for tick in names for name in tick if name != "idle")
    assert idle > 0 if strategy == "all" else idle == 0


@pytest.mark.parametrize("strategy", ["continue", "any", "all", "primitive"])
def test_reward_accounting_matches_the_ticks(strategy: str) -> None:
    for _, point, _, nxt, (rewards, _, ticks) in play(strategy, seed=3, episodes=1):
        assert nxt.duration == len(rewards) >= 1
        assert nxt.reward == pytest.approx(sum(rewards))
        discounted = sum(GAMMA**j * r for j, r in enumerate(rewards))
        assert nxt.discounted_reward == pytest.approx(discounted)
        assert nxt.ticks == point.ticks + nxt.duration == ticks[-1]
        if nxt.done:
            assert nxt.info["episode"]["ticks"] == nxt.ticks


def test_observations_refresh_only_for_choosing_agents() -> None:
    env = make_env("tool_delivery", "continue", seed=0, images=True, image_size=48)
    policy = RandomPolicy(env.spec, 0)
    point = env.reset()
    assert point.images.shape == (3, 48, 48, 3) and point.images.std() > 0
    prev_vectors = [v.copy() for v in point.vectors]
    prev_images = point.images.copy()
    for _ in range(15):
        point = env.step(policy(point))
        if point.done:
            break
        for i in np.flatnonzero(~point.choosing):
            assert np.array_equal(point.vectors[i], prev_vectors[i])
            assert np.array_equal(point.images[i], prev_images[i])
        prev_vectors = [v.copy() for v in point.vectors]
        prev_images = point.images.copy()
    env.close()


def test_same_seed_same_trajectory() -> None:
    def trajectory(seed: int) -> list[tuple]:
        out = []
        for env, _, joint, nxt, _ in play("continue", seed, episodes=1):
            state = env.task.scene.state()
            out.append((tuple(joint), nxt.reward, nxt.ticks, state["qpos"].tobytes()))
        return out

    assert trajectory(5) == trajectory(5)
    assert trajectory(5) != trajectory(6)


@pytest.mark.parametrize("bad", [-1, 1.5, "3", True, None])
def test_seeds_are_integers_at_least_zero_in_the_python_api_too(bad) -> None:
    """The command lines refuse negative seeds; so do ``make_env`` and ``reset`` (numpy's own
    error would not name the seed, and a bool would pass as 1)."""
    if bad is not None:
        with pytest.raises(ValueError, match=r"^seed must be an integer >= 0"):
            make_env("tool_delivery", "continue", seed=bad)
    env = make_env("tool_delivery", "continue", seed=np.int64(3))
    env.reset(seed=np.int64(4))
    if bad is not None:
        with pytest.raises(ValueError, match=r"^reset seed must be an integer >= 0"):
            env.reset(seed=bad)
    env.close()


def test_bad_input_raises_value_errors_that_name_the_agent() -> None:
    env = make_env("tool_delivery", "continue", overrides={"mask_options": True})
    point = env.reset()
    with pytest.raises(ValueError, match=r"turtlebot0.*must choose"):
        env.step([-1, 0, 2])
    with pytest.raises(ValueError, match=r"fetch.*out of range"):
        env.step([0, 0, 6])
    with pytest.raises(ValueError, match=r"PassTo\(0\).*fetch.*not available"):
        env.step([0, 0, 0])  # nothing is staged yet
    with pytest.raises(ValueError, match="3 integers"):
        env.step([0, 0])
    point = env.step([2, 2, 2])  # both GetTool, SearchTool(0): the Fetch ends first
    assert list(point.choosing) == [False, False, True]
    with pytest.raises(ValueError, match=r"turtlebot0.*is executing 'GetTool'"):
        env.step([0, 2, 5])
    point = env.step([-1, -1, 5])  # -1 for continuing agents is accepted
    while not point.done:  # GoToTR / Wait until the 150-tick limit
        point = env.step(np.where(point.choosing, [1, 1, 5], point.running))
    assert point.truncated and point.ticks == 150
    with pytest.raises(ValueError, match="after the episode ended"):
        env.step([0, 0, 5])
    with pytest.raises(ValueError, match="unknown task"):
        make_env("no_such_task")
    with pytest.raises(ValueError, match=r"did you mean 'env\.max_ticks'"):
        make_env("tool_delivery", overrides={"max_tick": 10})
    env.close()


def test_an_episode_whose_physics_mujoco_reset_ends_truncated_and_unsolved(
    tmp_path, monkeypatch
) -> None:
    """A 20-tick Water Filling episode is solved when no jar runs dry; with a vehicle whose
    heading servo is far too stiff, MuJoCo resets the physics in the first tick, and that
    episode used to be reported solved with its full return too."""
    monkeypatch.setattr(robots, "_REGISTRY", dict(robots._REGISTRY))
    monkeypatch.chdir(tmp_path)  # MuJoCo logs the instability to MUJOCO_LOG.TXT
    clamped = 'forcerange="-80 80"/>\n  </actuator>'  # the yaw servo's force limit
    text = (ASSETS_DIR / "robots" / "vehicle.xml").read_text()
    assert clamped in text
    (tmp_path / "vehicle.xml").write_text(text.replace(clamped, "/>\n  </actuator>"))
    stiff = VehicleConstants(yaw_kp=1e6, yaw_kv=0.0)
    register_robot("stiff_vehicle", tmp_path / "vehicle.xml", VehicleAdapter, stiff)

    def last_point(**overrides) -> DecisionPoint:
        env = make_env("water_filling", overrides={"max_ticks": 20, **overrides})
        nav = [a.option_index("NavTo(1)") for a in env.spec.agents]
        point = env.reset()
        while not point.done:
            point = env.step(np.where(point.choosing, nav, point.running))
        env.close()
        return point

    healthy = last_point()
    assert healthy.info["episode"]["solved"] and "physics_warning" not in healthy.info
    point = last_point(vehicle_robot="stiff_vehicle")
    assert point.truncated and not point.terminated and point.ticks < 20
    assert "mjWARN_BADQACC" in point.info["physics_warning"]
    assert "robot 'vehicle'" in point.info["physics_warning"]
    assert not point.info["episode"]["solved"]
    assert point.duration >= 1 and point.reward == 0.0, "the lost tick counts, unrewarded"
    assert point.choosing.all()


def test_pettingzoo_parallel_api() -> None:
    env = OptionParallelEnv(make_env("tool_delivery", "continue", seed=0))
    parallel_api_test(env, num_cycles=400)
    obs, infos = env.reset(seed=1)
    assert set(obs) == {"turtlebot0", "turtlebot1", "fetch"}
    _, rewards, _, _, infos = env.step({"turtlebot0": 2, "turtlebot1": 2, "fetch": 2})
    assert rewards["fetch"] == -6.0 and infos["fetch"]["duration"] == 6
    assert not infos["turtlebot0"]["choosing"]
    assert obs["fetch"]["action_mask"].sum() == 6
    env.close()


def test_decision_point_is_documented_contract() -> None:
    env = make_env("tool_delivery")
    point = env.reset()
    assert isinstance(point, DecisionPoint)
    assert point.choosing.all() and (point.running == -1).all()
    assert [len(m) for m in point.available] == [3, 3, 6]
    assert [v.shape for v in point.vectors] == [(14,), (14,), (5,)]
    assert env.spec.option_counts == (3, 3, 6)
    env.close()
