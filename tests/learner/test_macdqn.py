"""Mac-DQN: conditional argmax, double-Q target, squeezed replay, ε-greedy, resume, learning."""

from __future__ import annotations

import itertools
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from maopg.env import make_env
from maopg.env.contract import AgentSpec, EnvSpec, Strategy
from maopg.env.rollout import RandomPolicy, run_episode
from maopg.experiment.cli.train_cli import main as train_main
from maopg.experiment.run.config import TrainConfig
from maopg.experiment.run.directory import TIMING_COLUMNS, read_metrics
from maopg.experiment.training.trainer import train
from maopg.learner.checkpoint import load_checkpoint
from maopg.learner.macdqn import MacDQN, MacDQNConfig, double_q_target, joint_q_network
from maopg.learner.replay import SqueezedReplay, point_arrays
from maopg.policy import JointQNetwork, ObsBatch, conditional_argmax, epsilon_greedy, ravel_joint
from maopg.policy.joint_size import BuildTarget, joint_head_bytes, require_joint_head_fits

REPO = Path(__file__).resolve().parents[2]


def _random_conditions(rng: np.random.Generator, counts: tuple[int, ...], batch: int):
    """Random (choosing, running, available) rows where every choosing agent has an option."""
    n = len(counts)
    choosing = rng.random((batch, n)) < 0.5
    running = np.stack([rng.integers(0, k, batch) for k in counts], axis=1)
    masks = []
    for k in counts:
        mask = rng.random((batch, k)) < 0.6
        mask[np.arange(batch), rng.integers(0, k, batch)] = True
        masks.append(mask)
    return (
        torch.from_numpy(choosing),
        torch.from_numpy(running),
        torch.from_numpy(np.concatenate(masks, axis=1)),
    )


def _brute_force_argmax(q, choosing, running, available, counts):
    offsets = np.cumsum((0, *counts))
    best, best_value = None, -math.inf
    for joint in itertools.product(*(range(k) for k in counts)):
        ok = all(
            available[offsets[i] + o] if choosing[i] else o == running[i]
            for i, o in enumerate(joint)
        )
        flat = int(np.ravel_multi_index(joint, counts))
        if ok and q[flat] > best_value:
            best, best_value = flat, q[flat]
    return best


@pytest.mark.parametrize("counts", [(4,), (2, 5), (3, 3, 6), (2, 3, 2, 2)])
def test_conditional_argmax_matches_brute_force(counts):
    rng = np.random.default_rng(len(counts))
    batch = 64
    choosing, running, available = _random_conditions(rng, counts, batch)
    q = torch.randn(batch, math.prod(counts), generator=torch.Generator().manual_seed(1))
    got = conditional_argmax(q, choosing, running, available, counts)
    for b in range(batch):
        expected = _brute_force_argmax(
            q[b].numpy(), choosing[b].numpy(), running[b].numpy(), available[b].numpy(), counts
        )
        assert int(got[b]) == expected
    assert choosing.any() and (~choosing).any()  # both kinds of agents were exercised


def test_double_q_target_hand_computed_with_unequal_durations():
    """Two agents with K = (2, 3): flat index = 3·o_0 + o_1; γ = 0.9."""
    counts, gamma = (2, 3), 0.9
    online = torch.zeros(4, 6)
    target = torch.zeros(4, 6)
    # Row 0: agent 0 chooses (both options available), agent 1 keeps running option 2, so the
    # slice is {(0,2), (1,2)} = flat {2, 5}. Online prefers 5 (3 > 1; flat 0 = 10 is outside the
    # slice); the target net's value there is 4 (its own max, 100 at flat 2, must not be used).
    online[0, [0, 2, 5]] = torch.tensor([10.0, 1.0, 3.0])
    target[0, [2, 5]] = torch.tensor([100.0, 4.0])
    # Row 1: agent 1 chooses among {1, 2}, agent 0 keeps 0: slice flat {1, 2}; online picks 1.
    online[1, [1, 2, 3]] = torch.tensor([2.0, 1.5, 50.0])
    target[1, 1] = -6.0
    # Row 2: terminal with nothing available: no bootstrap. Row 3: truncated, all choose, all
    # available: bootstraps like any non-terminal (online max at flat 4, target there 2).
    online[2] = 7.0
    target[2] = 7.0
    online[3, 4] = 9.0
    target[3, 4] = 2.0
    y = double_q_target(
        reward=torch.tensor([5.0, -2.0, 100.0, -4.0]),
        duration=torch.tensor([3, 1, 2, 4]),
        terminated=torch.tensor([False, False, True, False]),
        next_q_online=online,
        next_q_target=target,
        next_choosing=torch.tensor([[True, False], [False, True], [True, True], [True, True]]),
        next_running=torch.tensor([[1, 2], [0, 0], [0, 1], [1, 0]]),
        next_available=torch.tensor(
            [[1, 1, 0, 0, 0], [0, 0, 0, 1, 1], [0, 0, 0, 0, 0], [1, 1, 1, 1, 1]], dtype=torch.bool
        ),
        option_counts=counts,
        gamma=gamma,
    )
    expected = [5.0 + 0.729 * 4.0, -2.0 + 0.9 * -6.0, 100.0, -4.0 + 0.6561 * 2.0]
    assert y.tolist() == pytest.approx(expected)  # [7.916, -7.4, 100.0, -2.6878]


def _fill_replay(episodes: int, seed: int = 0) -> tuple[SqueezedReplay, list[dict], int]:
    """Play ``episodes`` random Tool Delivery episodes in one env into a fresh replay."""
    env = make_env("tool_delivery", seed=seed)
    policy = RandomPolicy(env.spec, seed)
    replay = SqueezedReplay(env.spec, capacity=10_000, num_envs=1)
    log = []
    try:
        for _ in range(episodes):
            point = env.reset()
            steps, ticks = 0, 0
            while not point.done:
                before = point_arrays(point)
                assert point.choosing.any()  # the env only stops at decision points
                joint = policy(point)
                point = env.step(joint)
                replay.add(0, before, joint, point)
                steps, ticks = steps + 1, ticks + point.duration
                if not point.done:
                    assert len(replay) == sum(e["steps"] for e in log)  # held back until the end
            log.append({"steps": steps, "ticks": ticks, "terminated": point.terminated})
    finally:
        env.close()
    return replay, log, env.spec.max_ticks


def test_replay_stores_one_row_per_decision_point():
    replay, log, _ = _fill_replay(4)
    assert len(replay) == sum(e["steps"] for e in log)
    assert [n for _, n in replay.episodes] == [e["steps"] for e in log]
    data = {k: v[: len(replay)] for k, v in replay.data.items()}
    assert (data["duration"] >= 1).all()
    assert data["choosing"].any(axis=1).all()  # every stored row is a decision point
    for (start, n), episode in zip(replay.episodes, log, strict=True):
        rows = slice(start, start + n)
        assert data["duration"][rows].sum() == episode["ticks"]
        # Squeezed: the next point of a row is the point of the following row.
        assert np.array_equal(data["next_vectors"][rows][:-1], data["vectors"][rows][1:])
        assert np.array_equal(data["next_running"][rows][:-1], data["running"][rows][1:])
        assert data["terminated"][rows][:-1].sum() == 0
        assert bool(data["terminated"][rows][-1]) == episode["terminated"]
    sequences = replay.sample_episodes(3, torch.Generator().manual_seed(0))
    lengths = sequences["mask"].sum(dim=1).tolist()
    assert set(lengths) <= {e["steps"] for e in log}
    assert sequences["joint"].shape[:2] == (3, max(lengths))


def test_replay_ring_drops_overwritten_episodes_and_round_trips():
    replay, log, _ = _fill_replay(3, seed=1)
    small = SqueezedReplay(make_env("tool_delivery").spec, capacity=150, num_envs=1)
    rows = [{k: v[i] for k, v in replay.data.items()} for i in range(len(replay))]
    start = 0
    for episode in log:
        small._commit(rows[start : start + episode["steps"]])
        start += episode["steps"]
    assert len(small) == min(150, len(replay))
    assert all(s >= small.total - small.capacity for s, _ in small.episodes)
    copy = SqueezedReplay(make_env("tool_delivery").spec, capacity=150, num_envs=1)
    copy.load_state_dict(small.state_dict())
    gen_a, gen_b = torch.Generator().manual_seed(3), torch.Generator().manual_seed(3)
    a, b = small.sample(32, gen_a), copy.sample(32, gen_b)
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_epsilon_greedy_stays_in_the_conditional_slice():
    counts = (3, 3, 6)
    rng = np.random.default_rng(7)
    batch = 4000
    choosing, running, available = _random_conditions(rng, counts, batch)
    q = torch.randn(batch, math.prod(counts), generator=torch.Generator().manual_seed(0))
    greedy = conditional_argmax(q, choosing, running, available, counts)
    offsets = np.cumsum((0, *counts))
    for epsilon in (0.0, 0.5, 1.0):
        joint = epsilon_greedy(
            q, choosing, running, available, counts, epsilon, torch.Generator().manual_seed(1)
        )
        assert torch.equal(joint[~choosing], running[~choosing])
        for i in range(len(counts)):
            rows = choosing[:, i]
            picked = available[rows, offsets[i] + joint[rows, i]]
            assert picked.all()
        matches = (ravel_joint(joint, counts) == greedy).float().mean()
        if epsilon == 0.0:
            assert matches == 1.0
        else:
            assert matches < 1.0
    # ε = 1: every available option of a choosing agent gets picked sometimes.
    for i, k in enumerate(counts):
        rows = choosing[:, i] & available[:, offsets[i] : offsets[i + 1]].all(dim=1)
        assert set(joint[rows, i].tolist()) == set(range(k))


def test_recurrent_training_targets_match_step_by_step_acting():
    """The padded-episode pass gives the same Q and targets as running the GRU point by point."""
    replay, _, _ = _fill_replay(3, seed=2)
    torch.manual_seed(0)
    spec = make_env("tool_delivery").spec
    q = JointQNetwork(spec, hidden=32, recurrent=True)
    learner = MacDQN(q, MacDQNConfig(recurrent=True, batch_episodes=3))
    with torch.no_grad():
        learner.target.head.weight.mul_(-0.5)  # make target and online nets differ
    seq = replay.sample_episodes(3, torch.Generator().manual_seed(5))
    q_taken, target = learner._sequence_values(seq)
    expected_q, expected_y = [], []
    mask = seq["mask"]
    for b in range(mask.shape[0]):
        n = int(mask[b].sum())
        points = torch.cat([seq["vectors"][b, :1], seq["next_vectors"][b, :n]])
        h_online = learner.q.initial_state(1)
        h_target = learner.target.initial_state(1)
        qs, ts = [], []
        with torch.no_grad():
            for t in range(n + 1):
                q, h_online = learner.q.step(ObsBatch(points[t : t + 1]), h_online)
                tq, h_target = learner.target.step(ObsBatch(points[t : t + 1]), h_target)
                qs.append(q[0])
                ts.append(tq[0])
        qs, ts = torch.stack(qs), torch.stack(ts)
        flat = ravel_joint(seq["joint"][b, :n], spec.option_counts)
        expected_q.append(qs[:n].gather(1, flat[:, None]).squeeze(1))
        expected_y.append(
            double_q_target(
                reward=seq["reward"][b, :n],
                duration=seq["duration"][b, :n],
                terminated=seq["terminated"][b, :n],
                next_q_online=qs[1:],
                next_q_target=ts[1:],
                next_choosing=seq["next_choosing"][b, :n],
                next_running=seq["next_running"][b, :n],
                next_available=seq["next_available"][b, :n],
                option_counts=spec.option_counts,
                gamma=0.99,
            )
        )
    torch.testing.assert_close(q_taken.detach(), torch.cat(expected_q), rtol=1e-5, atol=1e-4)
    torch.testing.assert_close(target, torch.cat(expected_y), rtol=1e-5, atol=1e-4)
    stats = learner.update(replay, torch.Generator().manual_seed(0))
    assert math.isfinite(stats["loss"])


# ---------------------------------------------------------------------------- training runs
TINY = [
    "--method",
    "mac-dqn",
    "--total-samples",
    "1200",
    "batch_ticks=100",
    "num_envs=2",
    "checkpoint_every=2",
    "hidden=32",
    "progress=false",
    "video=false",
    "eval_episodes=0",
    "plot=false",
    "torch_threads=1",
    "dqn.learning_starts=200",
    "dqn.train_every=10",
    "dqn.target_update_every=300",
]
"""A ``python -m train`` Mac-DQN run of 12 iterations with updates and target syncs."""


def _metrics(run_dir: Path) -> list[dict[str, str]]:
    return [
        {k: v for k, v in r.items() if k not in TIMING_COLUMNS}
        for r in read_metrics(run_dir / "metrics.csv")
    ]


@pytest.mark.parametrize("recurrent", [False, True])
def test_killed_run_resumes_bit_for_bit(tmp_path, recurrent):
    args = [*TINY, f"dqn.recurrent={recurrent}"]
    whole = tmp_path / "whole"
    train_main([*args, "--run-dir", str(whole)])
    assert int(_metrics(whole)[-1]["updates"]) > 0

    killed = tmp_path / "killed"
    proc = subprocess.Popen(
        [sys.executable, "-m", "train", *args, "--run-dir", str(killed)], cwd=REPO
    )
    try:
        deadline = time.monotonic() + 120
        while not (killed / "checkpoint.pt").exists():
            assert proc.poll() is None, "the run ended before writing a checkpoint"
            assert time.monotonic() < deadline
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    saved = load_checkpoint(killed / "checkpoint.pt")["iteration"]
    assert saved < len(_metrics(whole)), "killed too late to exercise resume"

    train_main(["--resume", "--run-dir", str(killed), "progress=false"])
    assert _metrics(killed) == _metrics(whole)
    a = load_checkpoint(killed / "final.pt")["q"]
    b = load_checkpoint(whole / "final.pt")["q"]
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_resume_rejects_a_changed_config(tmp_path, user_error):
    run = ["--run-dir", str(tmp_path / "run")]
    train_main([*TINY, *run, "--total-samples", "200"])
    resume = [*TINY, *run, "--resume", "dqn.lr=1e-3"]
    user_error(train_main, resume, r"dqn\.lr \(saved 0\.0006, given 0\.001\)")
    user_error(train_main, [*TINY, *run], "already holds a run")


@pytest.mark.slow
def test_learns_to_beat_the_random_policy(tmp_path):
    """Seeded smoke run on Tool Delivery (state observations): the Mac-DQN agent's mean return
    over its last 20 iterations beats the uniform-random policy's, measured here on the same
    environment, by 100. The run is the first 15K samples of the paper study's seed-0 run
    (``results/runs/tool_delivery/mac-dqn``; the same rows bit for bit on the machine that
    trained it, whose curves are bit-exact per machine); at 15K the five seeds
    there read 157.9, 159.8, 139.4, 143.6 and 158.3 over their last 20 iterations, where the bar
    is −20.0 + 100 (at 20K seed 2 dips to 96.7)."""
    env = make_env("tool_delivery", seed=123)
    try:
        random_returns = [run_episode(env, RandomPolicy(env.spec, 123)).ret for _ in range(60)]
    finally:
        env.close()
    config = TrainConfig(
        method="mac-dqn",
        seed=0,
        total_samples=15_000,
        progress=False,
        video=False,
        eval_episodes=0,
        torch_threads=1,
        run_dir=str(tmp_path / "smoke"),
    )
    returns = np.array([float(r["episode_return"]) for r in _metrics(train(config))])
    late = float(np.nanmean(returns[-20:]))
    random_mean = float(np.mean(random_returns))
    print(f"Mac-DQN last 20 iterations {late:.1f} vs random {random_mean:.1f}")
    assert late > random_mean + 100.0


def _team_spec(option_counts: tuple[int, ...]) -> EnvSpec:
    agents = tuple(
        AgentSpec(f"robot{i}", "turtlebot", tuple(f"o{j}" for j in range(k)), vector_size=4)
        for i, k in enumerate(option_counts)
    )
    return EnvSpec("team", Strategy.CONTINUE, agents, None, 1.0, 150, 0.99)


def test_a_team_too_large_for_the_joint_q_is_refused_with_its_size() -> None:
    """Eight agents (6^7·8 joint options, ~1.1 GiB of head weights alone, ×5 copies) exceed half
    of a 4 GiB machine; the refusal names the joint size and the way out, before allocating."""
    counts = (6,) * 7 + (8,)
    with pytest.raises(ValueError, match=r"6\^7·8 = 2,239,488 joint options.*async-ar"):
        require_joint_head_fits(
            counts,
            hidden=128,
            copies=5,
            rows=192,
            who="q",
            instead="use async-ar",
            target=BuildTarget(4 << 30, "this machine's"),
        )
    need = joint_head_bytes(counts, hidden=128, copies=5, rows=192)
    require_joint_head_fits(
        counts,
        hidden=128,
        copies=5,
        rows=192,
        who="q",
        instead="-",
        target=BuildTarget(2 * need + 1, "this machine's"),
    )
    # Through the method's builder on this machine's own memory: a 16-agent team cannot fit
    # anywhere (6^16 options), the paper's team builds.
    config, machine = MacDQNConfig(), BuildTarget.this_machine()
    with pytest.raises(ValueError, match=r"mac-dqn's Q-network .* 6\^16 = 2,821,109,907,456"):
        joint_q_network(_team_spec((6,) * 16), hidden=128, layers=2, config=config, target=machine)
    q = joint_q_network(_team_spec((3, 3, 6)), hidden=16, layers=1, config=config, target=machine)
    assert q.head.out_features == 54
