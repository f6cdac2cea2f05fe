"""Box Pushing on a grid against the reference (``box_pushing_reference.md``): the scripted
episode tick by tick, the random policy's statistics, and a hand-worked case of every rule and
quirk — on the rules (:class:`GridWorld`) and through the option environment."""

from __future__ import annotations

import csv
import itertools
from pathlib import Path

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test
from scipy.stats import chisquare

from maopg.env import Strategy, make_env
from maopg.env.pettingzoo import parallel_env
from maopg.env.rollout import RandomPolicy, reference_policy, run_episode
from maopg.env.video import record_episode
from maopg.tasks import make_config
from maopg.tasks.box_pushing_grid.config import Config
from maopg.tasks.box_pushing_grid.world import (
    MACROS,
    PRIMITIVES,
    RUNNING,
    WEST,
    GridWorld,
)

TASK = "box_pushing_grid"
# The canonical env's scripted 6x6 episode, tick by tick (copied from the project's shared
# reference material).
TRACE = Path(__file__).parents[1] / "data" / "box_pushing_scripted_trace_6x6.csv"
CANONICAL = dict(
    zip(("GT_SB0", "GT_SB1", "GT_BB0", "GT_BB1", "Push", "T_L", "T_R", "Stay"), MACROS, strict=True)
)
"""The canonical env's macro-action names -> ours."""
GT_SB0, GT_SB1, GT_BB0, GT_BB1, PUSH, T_L, T_R, STAY = range(8)
FORWARD, P_LEFT, P_RIGHT, P_STAY = range(4)
SCRIPTED = {4: (4, 299.6), 6: (6, 299.4), 8: (8, 299.2), 10: (11, 298.9)}
"""Reference §6: the scripted policy's length and return per grid size."""
RANDOM = {  # reference §7: mean return, its SE, mean length, its SE, outcome percentages
    4: (3.57, 0.75, 27.9, 0.5, (0.80, 96.25, 0.55, 2.40)),
    6: (2.68, 0.66, 33.7, 0.6, (0.45, 94.55, 0.45, 4.55)),
    8: (4.70, 0.69, 36.5, 0.6, (0.70, 93.90, 0.60, 4.80)),
    10: (3.25, 0.64, 42.3, 0.6, (0.45, 90.90, 0.55, 8.10)),
}
"""Outcomes in the order big box, one small box, two small boxes, timeout."""
EPISODES = 2000


def world(size: int = 6, agents: int = 2) -> GridWorld:
    return GridWorld(Config(size=size, agents=agents))


def run(w: GridWorld, plan: list[tuple[int, ...]]) -> list[float]:
    """Each agent issues the next action of its plan whenever its macro-action is done."""
    rewards = []
    for step in plan:
        rewards.append(
            w.step([a if agent.done else RUNNING for a, agent in zip(step, w.agents, strict=True)])
        )
    return rewards


def bits(w: GridWorld, i: int) -> str:
    return "".join(str(int(b)) for b in w.observations[i])


def where(w: GridWorld, i: int) -> tuple[float, float, str]:
    agent = w.agents[i]
    return agent.x, agent.y, "NESW"[agent.ori]


# --------------------------------------------------------------------------- the reference
def test_the_scripted_episode_reproduces_the_reference_trace_tick_by_tick() -> None:
    env = make_env(TASK)
    task = env.task
    rows: list[dict[str, str]] = []

    def record(reward: float | None) -> None:
        """One row of the trace: after a tick, or at reset (``reward`` None)."""
        w = task.world
        row = {"step": str(w.ticks)}
        for i, agent in enumerate(w.agents):
            issued = w.issued[i]
            row |= {
                f"a{i}_issued": "" if reward is None else ("-" if issued < 0 else MACROS[issued]),
                f"a{i}_cur_mac": MACROS[agent.macro] if agent.macro >= 0 else "",
                f"a{i}_done": str(int(agent.done)),
                f"a{i}_x": f"{agent.x:g}",
                f"a{i}_y": f"{agent.y:g}",
                f"a{i}_ori": "NESW"[agent.ori],
                f"a{i}_obs": bits(w, i),
            }
        for name, box in zip(("sb0", "sb1", "bb"), w.boxes, strict=True):
            row |= {f"{name}_x": f"{box.x:g}", f"{name}_y": f"{box.y:g}"}
        row["reward"] = "" if reward is None else f"{reward:g}"
        row["terminate"] = str(int(task.terminated()))
        rows.append(row)

    env.add_tick_listener(lambda _env, reward: record(reward))
    policy = reference_policy("scripted", env)
    point = env.reset()
    record(None)
    while not point.done:
        point = env.step(policy(point))
    env.close()

    with TRACE.open() as f:
        reference = list(csv.DictReader(f))
    assert len(rows) == len(reference) == 7
    for ours, theirs in zip(rows, reference, strict=True):
        for key, value in theirs.items():
            if key.endswith(("_issued", "_cur_mac")):
                value = CANONICAL.get(value, value)
            elif key.endswith(("_x", "_y")) or key == "reward":
                value = value and f"{float(value):g}"
            assert ours[key] == value, (theirs["step"], key)
    assert point.terminated and not point.truncated and point.info["episode"]["solved"]


@pytest.mark.parametrize("strategy", ["continue", "any", "all"])
@pytest.mark.parametrize("size", sorted(SCRIPTED))
def test_the_scripted_policy_is_optimal_at_every_size(size: int, strategy: str) -> None:
    ticks, ret = SCRIPTED[size]
    for agents in (2, 3):
        env = make_env(TASK, strategy, overrides={"size": size, "agents": agents})
        result = run_episode(env, reference_policy("scripted", env))
        env.close()
        assert result.solved and result.ticks == ticks and result.ret == pytest.approx(ret)


def _outcome(w: GridWorld) -> int:
    small0, small1, big = w.delivered()
    return 0 if big else 2 if small0 and small1 else 1 if small0 or small1 else 3


def _check_random_statistics(size: int, returns, lengths, outcomes) -> None:
    """Means within 3 standard errors of the difference, outcome counts by a χ² test. (Drawn
    with the reference's own seed, ``1000 + n``, the figures even come out digit for digit.)"""
    mean, se, length, length_se, percent = RANDOM[size]
    returns, lengths = np.asarray(returns), np.asarray(lengths)
    for ours, theirs, their_se in ((returns, mean, se), (lengths, length, length_se)):
        our_se = ours.std(ddof=1) / np.sqrt(len(ours))
        assert abs(ours.mean() - theirs) <= 3 * np.hypot(our_se, their_se), (ours.mean(), theirs)
    counts = np.bincount(outcomes, minlength=4)
    expected = np.asarray(percent) / np.sum(percent) * len(outcomes)
    assert chisquare(counts, expected).pvalue > 0.01, counts


def test_random_statistics_through_the_option_environment() -> None:
    """The reference's random protocol is ``continue`` with uniform options: 6x6, 2000 episodes
    through the whole option layer (uniform over the 8 on each agent's own macro end)."""
    env = make_env(TASK, seed=0)
    policy = RandomPolicy(env.spec, 1006)
    returns, lengths, outcomes = [], [], []
    for _ in range(EPISODES):
        result = run_episode(env, policy)
        returns.append(result.ret)
        lengths.append(result.ticks)
        outcomes.append(_outcome(env.task.world))
        assert result.solved == (outcomes[-1] == 0)
    env.close()
    _check_random_statistics(6, returns, lengths, outcomes)


@pytest.mark.parametrize("size", [4, 8, 10])
def test_random_statistics_on_the_rules(size: int) -> None:
    """The same protocol on the rules alone, at the other sizes (3x faster than the env)."""
    w, rng = world(size), np.random.default_rng(1000 + size)
    returns, lengths, outcomes = [], [], []
    for _ in range(EPISODES):
        w.reset()
        ret = 0.0
        while not w.terminated() and w.ticks < 100:
            ret += w.step([int(rng.integers(8)) if a.done else RUNNING for a in w.agents])
        returns.append(ret)
        lengths.append(w.ticks)
        outcomes.append(_outcome(w))
    _check_random_statistics(size, returns, lengths, outcomes)


# --------------------------------------------------------------------------- navigation
def test_goto_durations_from_the_starts_and_from_everywhere() -> None:
    """Reference §3.3: ticks of each GoTo from the start positions, the longest GoTo from any
    free cell and orientation, and the 32 starts in the top row of 4x4 that never arrive."""
    from_starts = {
        4: ([2, 5, 3, 4], [5, 2, 4, 3]),
        6: ([2, 7, 4, 5], [7, 2, 5, 4]),
        8: ([3, 8, 5, 6], [8, 3, 6, 5]),
        10: ([4, 11, 7, 8], [11, 4, 8, 7]),
    }
    longest = {4: 16, 6: 18, 8: 20, 10: 22}

    def duration(w: GridWorld, goto: int) -> int | None:
        for tick in range(1, 60):
            w.step([goto if tick == 1 else RUNNING, STAY])
            if w.agents[0].done:
                return tick
        return None

    for size in from_starts:
        w = world(size)
        for i in (0, 1):
            ticks = []
            for goto in range(4):
                w.reset()
                plan = [(goto, STAY)] if i == 0 else [(STAY, goto)]
                run(w, plan)
                while not w.agents[i].done:
                    run(w, plan)
                ticks.append(w.ticks)
            assert ticks == from_starts[size][i], (size, i)
        boxes = {(b.x + dx, b.y) for b in w.boxes for dx in ((-0.5, 0.5) if b.big else (0.0,))}
        durations = []
        for x, y, ori, goto in itertools.product(range(size), range(size), range(4), range(4)):
            if (x + 0.5, y + 0.5) in boxes:
                continue
            w.reset()
            w.agents[0].x, w.agents[0].y, w.agents[0].ori = x + 0.5, y + 0.5, ori
            durations.append(duration(w, goto))
        assert max(d for d in durations if d is not None) == longest[size]
        assert durations.count(None) == (32 if size == 4 else 0)


def test_navigation_ignores_the_walls() -> None:
    """Reference §3.3: on 6x6 a GoTo started above the box row walks one column outside the
    grid and comes back in at its waypoint: from (0.5, 4.5) facing west, GoToSmallBox(0)
    steps out to x = -0.5 (no wall stops it, no penalty), walks south past the small box and
    steps back in to (0.5, 2.5); GoToSmallBox(1) from the same start crosses the grid and
    walks down outside it at x = 6.5."""
    w = world(6)
    for goto, outside in ((GT_SB0, -0.5), (GT_SB1, 6.5)):
        w.reset()
        a = w.agents[0]
        a.x, a.y, a.ori = 0.5, 4.5, WEST
        path, rewards = [], []
        rewards.append(w.step([goto, STAY]))
        path.append((a.x, a.y))
        while not a.done:
            rewards.append(w.step([RUNNING, STAY]))
            path.append((a.x, a.y))
        assert {(outside, y) for y in (4.5, 3.5, 2.5)} <= set(path), path
        assert (a.x, a.y) == w.layout.waypoints[goto] and a.waypoint == goto
        assert rewards == [-0.1] * len(rewards)  # no penalty on the way out or back


def test_goto_ends_on_the_waypoint_facing_north_and_records_it() -> None:
    w = world()
    run(w, [(GT_BB0, GT_BB1)] * 4)
    assert [where(w, i) for i in (0, 1)] == [(2.5, 2.5, "N"), (3.5, 2.5, "N")]
    assert [a.waypoint for a in w.agents] == [2, 3] and all(a.done for a in w.agents)
    assert bits(w, 0) == bits(w, 1) == "01000"
    run(w, [(GT_BB0, STAY)])  # already there: done at once, no move
    assert where(w, 0) == (2.5, 2.5, "N") and w.agents[0].done


def test_agents_never_block_each_other() -> None:
    # Both go to the same waypoint and end in one cell.
    w = world()
    run(w, [(GT_BB1, GT_BB1)] * 5)
    assert where(w, 0)[:2] == where(w, 1)[:2] == (3.5, 2.5) and all(a.done for a in w.agents)
    # A Push walks straight through the teammate, without a penalty.
    w = world()
    w.agents[1].x = 2.5
    rewards = run(w, [(PUSH, STAY)] * 5)
    assert where(w, 0) == (5.5, 1.5, "E") and w.agents[0].done
    assert rewards == pytest.approx([-0.1] * 5)
    # A GoTo plans through the teammate as if it were not there.
    w = world()
    w.agents[1].x, w.agents[1].ori = 1.5, 3  # right in front of agent 0
    run(w, [(GT_BB0, STAY)])
    assert where(w, 0) == (1.5, 1.5, "E")


def test_navigation_blocks_small_box_zeros_row_not_the_real_box_cells() -> None:
    """The blocked row is small box 0's current y: once it has moved, an agent may walk into a
    real box cell."""
    for small0_y, first_step in ((3.5, (2.5, 4.5, "E")), (4.5, (2.5, 3.5, "S"))):
        w = world()
        w.boxes[0].y = small0_y
        w.agents[0].x, w.agents[0].y, w.agents[0].ori = 2.5, 4.5, 2  # above the big box
        run(w, [(GT_BB0, STAY)])
        assert where(w, 0) == first_step  # ...turns east, or walks into the big box's cell


# --------------------------------------------------------------------------- pushing
def test_the_joint_push_reads_the_recorded_waypoint() -> None:
    """Reference §3.6: agent 0 reaches its waypoint, walks east to the wall and turns north;
    agent 1 waits on its waypoint. Both push: the big box is delivered, and agent 0 walks
    north through small box 1's cell without moving it."""
    w = world()
    run(w, [(GT_BB0, GT_BB1)] * 4 + [(T_R, STAY)])
    rewards = run(w, [(PUSH, STAY)] * 3)  # through agent 1's cell, to the wall
    assert where(w, 0) == (5.5, 2.5, "E") and rewards == pytest.approx([-0.1] * 3)
    run(w, [(T_L, STAY)])
    assert w.agents[0].waypoint == 2 and where(w, 0) == (5.5, 2.5, "N")
    rewards = run(w, [(PUSH, PUSH)] * 2)
    assert rewards == pytest.approx([-0.1, 299.9]) and w.terminated()
    assert where(w, 0) == (5.5, 4.5, "N") and where(w, 1) == (3.5, 4.5, "N")
    assert (w.boxes[1].x, w.boxes[1].y) == (5.5, 3.5) and w.delivered() == (False, False, True)
    assert all(a.done for a in w.agents)


def test_a_joint_push_needs_both_done_facing_north_and_issuing_push_together() -> None:
    w = world()
    run(w, [(GT_BB0, GT_BB1)] * 4)
    assert run(w, [(PUSH, STAY)]) == pytest.approx([-10.1])  # alone: the lone big-box penalty
    assert where(w, 0) == (2.5, 2.5, "N") and w.agents[0].done and not w.pushing_big_box
    # Two pushes in a row, one each: no joint push either.
    assert run(w, [(STAY, PUSH)]) == pytest.approx([-10.1])
    assert run(w, [(PUSH, PUSH)]) == pytest.approx([-0.1]) and w.pushing_big_box


def test_push_penalties() -> None:
    # At the border facing out: penalty, no move, one tick.
    w = world()
    rewards = run(w, [(T_L, STAY), (T_L, STAY), (PUSH, STAY)])
    assert rewards == pytest.approx([-0.1, -0.1, -10.1])
    assert where(w, 0) == (0.5, 1.5, "W") and w.agents[0].done
    # Into a small box from the side, into the big box from the side, into a box from above:
    # moved back, penalty, done. Two penalties on one tick add up.
    for x, y, ori in ((1.5, 3.5, 3), (1.5, 3.5, 1), (0.5, 4.5, 2)):
        w = world()
        w.agents[0].x, w.agents[0].y, w.agents[0].ori = x, y, ori
        w.agents[1].x, w.agents[1].y, w.agents[1].ori = 4.5, 3.5, 1  # into small box 1
        assert run(w, [(PUSH, PUSH)]) == pytest.approx([-20.1])
        assert where(w, 0) == (x, y, "NESW"[ori]) and all(a.done for a in w.agents)
        assert [(b.x, b.y) for b in w.boxes] == [(0.5, 3.5), (5.5, 3.5), (3.0, 3.5)]
    # Turns and Stay are never penalised, even facing a wall or a box.
    w = world()
    assert run(w, [(T_R, T_L)] * 4 + [(STAY, STAY)]) == pytest.approx([-0.1] * 5)


def test_small_boxes_go_north_until_delivered() -> None:
    """Reference §5: one small box in 4 ticks (19.6); both in the same tick (39.6 on 6x6)."""
    w = world()
    rewards = run(w, [(T_L, STAY), (PUSH, STAY), (PUSH, STAY), (PUSH, STAY)])
    assert sum(rewards) == pytest.approx(19.6) and w.terminated() and w.ticks == 4
    assert where(w, 0) == (0.5, 4.5, "N") and w.delivered() == (True, False, False)
    w = world()
    rewards = run(w, [(T_L, T_R)] + [(PUSH, PUSH)] * 3)
    assert sum(rewards) == pytest.approx(39.6) and w.delivered() == (True, True, False)
    for size, total in ((4, 39.7), (8, 39.4), (10, 39.2)):
        w = world(size)
        rewards = run(w, [(T_L, T_R)])
        while not w.terminated():
            rewards += run(w, [(PUSH, PUSH)])
        assert sum(rewards) == pytest.approx(total) and w.delivered() == (True, True, False)


# --------------------------------------------------------------------------- observations
def test_the_reset_observation_is_what_is_in_front() -> None:
    """The canonical env hard-codes 00100 at reset (00001 for agent 0 on 4x4 with three
    agents, who faces agent 2): what each agent sees at every start layout."""
    for size, agents in itertools.product((4, 6, 8, 10), (2, 3)):
        w = world(size, agents)
        expected = [
            "00001" if size == 4 and agents == 3 and i == 0 else "00100" for i in range(agents)
        ]
        assert [bits(w, i) for i in range(agents)] == expected, (size, agents)


def test_an_observation_is_refreshed_only_when_the_macro_action_ends() -> None:
    w = world()
    w.agents[1].x = 3.5  # agent 0's Push walks up to it, then through it
    run(w, [(PUSH, STAY)] * 2)
    assert where(w, 0) == (2.5, 1.5, "E") and where(w, 1) == (3.5, 1.5, "W")
    assert not w.agents[0].done and bits(w, 0) == "00100", "stale while its Push runs"
    assert w.agents[1].done and bits(w, 1) == "00001", "Stay ended: it sees agent 0"
    run(w, [(PUSH, STAY)] * 3)
    assert where(w, 0) == (5.5, 1.5, "E") and w.agents[0].done
    assert bits(w, 0) == "00010" and bits(w, 1) == "00100"  # the wall; agent 0 has gone by


def test_the_state_is_the_canonical_18_floats() -> None:
    env = make_env(TASK)
    env.reset()
    expected = [1 / 12, 0.25, 0, 1, 0, 0, 11 / 12, 0.25, 0, 0, 0, 1]
    expected += [1 / 12, 3.5 / 6, 11 / 12, 3.5 / 6, 0.5, 3.5 / 6]
    np.testing.assert_allclose(env.task.global_state(), expected, rtol=1e-6)
    assert env.task.global_state().dtype == np.float32
    env.close()


# --------------------------------------------------------------------------- the option layer
def test_options_observations_and_spec() -> None:
    env, primitive = make_env(TASK), make_env(TASK, "primitive")
    for spec, names in ((env.spec, MACROS), (primitive.spec, PRIMITIVES)):
        assert spec.agent_names == ("agent0", "agent1") and spec.max_ticks == 100
        assert all(agent.option_names == names for agent in spec.agents)
        assert spec.agents[0].layout.names == ("small_box", "big_box", "empty", "wall", "teammate")
    env.close()
    primitive.close()
    c = make_config(TASK)  # the published runs' settings (bp6)
    assert (c.size, c.agents, c.max_ticks, c.images) == (6, 2, 100, False)
    assert (c.big_box_reward, c.small_box_reward, c.penalty, c.step_reward) == (300, 20, -10, -0.1)


def test_each_agent_chooses_when_its_own_macro_action_ends() -> None:
    env = make_env(TASK)
    point = env.reset()
    assert point.choosing.all() and [v.tolist() for v in point.vectors] == [[0, 0, 1, 0, 0]] * 2
    point = env.step([GT_SB0, GT_SB1])  # 2 ticks for agent 0, 2 for agent 1
    assert point.ticks == 2 and point.choosing.all()
    point = env.step([GT_BB1, STAY])  # agent 0: 5 ticks from (0.5, 2.5); agent 1: 1 tick
    assert point.ticks == 3 and list(point.choosing) == [False, True]
    assert point.running.tolist() == [GT_BB1, STAY] and point.duration == 1
    before = point.vectors[0].copy()
    point = env.step([GT_BB1, PUSH])  # agent 1 pushes small box 1: 2 ticks, delivered
    assert point.terminated and point.ticks == 5 and point.reward == pytest.approx(19.8)
    np.testing.assert_array_equal(point.vectors[0], before)
    assert not point.info["episode"]["solved"]
    env.close()


def test_a_timeout_is_a_truncation() -> None:
    env = make_env(TASK)
    point = env.reset()
    while not point.done:
        point = env.step(np.where(point.choosing, STAY, -1))
    assert point.truncated and not point.terminated and point.ticks == 100
    assert point.info["episode"]["return"] == pytest.approx(-10.0)
    assert not point.info["episode"]["solved"]
    env.close()


def test_sync_cut_carries_a_cut_goto_on_and_sync_wait_stays() -> None:
    # any: agent 0 turns every tick, so agent 1's GoTo is cut every tick and chosen again; it
    # arrives as fast as uncut (4 ticks), and reaches the recorded waypoint.
    env = make_env(TASK, "any")
    env.reset()
    for _ in range(4):
        point = env.step([T_L, GT_BB1])
        assert point.duration == 1 and point.choosing.all()
    assert env.task.world.agents[1].waypoint == 3 and point.vectors[1].tolist() == [0, 1, 0, 0, 0]
    env.close()
    # all: agent 0's turn ends first; it stays (no move, no penalty) until agent 1 arrives.
    env = make_env(TASK, "all")
    env.reset()
    point = env.step([T_L, GT_BB1])
    assert point.ticks == 4 and point.choosing.all() and point.reward == pytest.approx(-0.4)
    assert where(env.task.world, 0) == (0.5, 1.5, "N")
    env.close()


def test_three_agents_any_two_can_push_the_big_box() -> None:
    w = world(6, agents=3)
    assert where(w, 2) == (2.5, 1.5, "N") and w.state().shape == (24,)
    assert where(world(4, agents=3), 2) == (1.5, 0.5, "N")
    run(w, [(STAY, GT_BB1, GT_BB0)] * 4)
    rewards = run(w, [(STAY, PUSH, PUSH)] * 2)
    assert rewards == pytest.approx([-0.1, 299.9]) and w.delivered() == (False, False, True)
    # Under sync-cut, agent 0's one-tick Stays cut the pushers' options: the push goes on.
    env = make_env(TASK, "any", overrides={"agents": 3})
    env.reset()
    for _ in range(4):
        point = env.step([STAY, GT_BB1, GT_BB0])
    point = env.step([STAY, PUSH, PUSH])
    assert point.duration == 1 and not point.done and env.task.world.pushing_big_box
    point = env.step([STAY, T_L, T_L])  # ignored: the pushers are carried with the box
    assert point.terminated and point.info["episode"]["solved"]
    env.close()


def test_primitive_actions_follow_bp_v0() -> None:
    w = GridWorld(Config(primitive=True))
    assert w.step_primitive([P_LEFT, FORWARD]) == pytest.approx(-0.1)
    assert where(w, 0) == (0.5, 1.5, "N") and where(w, 1) == (4.5, 1.5, "W")
    assert all(a.done for a in w.agents) and bits(w, 1) == "00100"  # fresh every tick
    w.reset()
    w.step_primitive([P_LEFT, P_STAY])
    w.step_primitive([P_LEFT, P_STAY])
    assert w.step_primitive([FORWARD, P_STAY]) == pytest.approx(-10.1)  # off the grid: undone
    assert where(w, 0) == (0.5, 1.5, "W")
    # The fastest big box: 4 moves and turns, then two joint pushes.
    w.reset()
    for step in ([FORWARD] * 2, [FORWARD] * 2, [P_LEFT, P_RIGHT], [FORWARD] * 2):
        w.step_primitive(step)
    rewards = [w.step_primitive([FORWARD, FORWARD]) for _ in range(2)]
    assert rewards == pytest.approx([-0.1, 299.9]) and w.delivered() == (False, False, True)
    # A pusher's flag is never cleared: skip one push and both walk off the top.
    w.reset()
    for step in ([FORWARD] * 2, [FORWARD] * 2, [P_LEFT, P_RIGHT], [FORWARD] * 2, [FORWARD] * 2):
        w.step_primitive(step)
    for _ in range(5):
        w.step_primitive([P_STAY, P_LEFT])
    assert (w.agents[0].y, w.agents[1].y) == (8.5, 8.5) and w.boxes[2].y == 4.5


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("size", 5, "env.size must be one of [4, 6, 8, 10], got 5"),
        ("agents", 4, "env.agents must be one of [2, 3], got 4"),
        ("max_ticks", 0, "env.max_ticks must be >= 1, got 0"),
        ("penalty", "x", "env.penalty"),
    ],
)
def test_bad_settings_are_refused_in_one_line(key: str, value: object, message: str) -> None:
    with pytest.raises(ValueError) as err:
        make_config(TASK, {key: value})
    assert message in str(err.value) and "\n" not in str(err.value)


def test_there_are_no_cameras() -> None:
    with pytest.raises(ValueError, match="has no cameras"):
        make_env(TASK, images=True)


def test_a_video_draws_the_grid_and_the_pettingzoo_view_works(tmp_path) -> None:
    env = make_env(TASK, "all")
    frame = env.task.video_frame()
    assert frame.shape == (480, 480, 3) and frame.dtype == np.uint8 and frame.std() > 10
    video = record_episode(env, reference_policy("scripted", env), tmp_path / "bp.mp4")
    assert (
        video.frames == 1 + 4 * 6 and video.solved
    )  # each tick drawn once, shown 4 times and video.path.stat().st_size > 0
    env.close()
    view = parallel_env(TASK, "continue", seed=0, render_mode="rgb_array", overrides={"size": 4})
    try:
        parallel_api_test(view, num_cycles=40)
        view.reset(seed=0)
        assert view.render().std() > 10
    finally:
        view.close()


@pytest.mark.parametrize("strategy", [s.value for s in Strategy])
def test_every_strategy_runs_random_episodes_with_three_agents(strategy: str) -> None:
    env = make_env(TASK, strategy, overrides={"agents": 3, "size": 10})
    policy = RandomPolicy(env.spec, 0)
    for _ in range(20):
        result = run_episode(env, policy)
        assert result.ticks <= 100 and np.isfinite(result.ret)
    env.close()
