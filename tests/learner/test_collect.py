"""MAPPO's collection loop over a seeded vector environment on the real Tool Delivery task, and
the vector environment's replay-based resume."""

import numpy as np
import pytest
import torch

from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.learner import LearnerSetup, MAPPOLearner, PPOConfig
from maopg.policy import CentralizedPolicy, ObsBatch

CONFIG = EnvConfig(task="tool_delivery", strategy="continue")


def _learner(envs: SeededVectorEnv, batch_ticks: int, seed: int = 0) -> MAPPOLearner:
    torch.manual_seed(0)
    setup = LearnerSetup(
        spec=envs.spec,
        config=PPOConfig(),
        num_envs=envs.num_envs,
        batch_ticks=batch_ticks,
        gamma=0.99,
        hidden=32,
        layers=2,
        sample_gen=torch.Generator().manual_seed(seed),
        update_gen=torch.Generator(),
    )
    return MAPPOLearner(CentralizedPolicy(envs.spec, hidden=32), setup)


@pytest.fixture
def envs():
    envs = SeededVectorEnv(CONFIG, num_envs=3, seed=11)
    yield envs
    envs.close()


def test_rollout_counts_ticks_and_respects_the_condition(envs):
    envs.reset()
    learner = _learner(envs, 400)
    policy = learner.policy
    reported: list[int] = []  # the progress hook sees every step's ticks, inside the batch
    envs.on_step = lambda _points, _joints, results: reported.append(
        sum(r.outcome.duration for r in results)
    )
    rollout = learner.collect(envs)
    durations = rollout.grid("duration")
    assert 400 <= rollout.ticks == int(durations.sum()) < 400 + 3 * 150
    assert len(reported) == rollout.num_steps and sum(reported) == rollout.ticks
    assert durations.min() >= 1
    choosing, running, joint = (rollout.grid(k) for k in ("choosing", "running", "joint"))
    assert choosing.any(axis=-1).all()  # every row is a decision point of every environment
    np.testing.assert_array_equal(joint[~choosing], running[~choosing])
    # A continuing agent's running option is the option it was given earlier in the episode.
    done = rollout.grid("terminated") | rollout.grid("truncated")
    for s in range(1, rollout.num_steps):
        fresh = ~done[s - 1]
        cont = ~choosing[s] & fresh[:, None]
        np.testing.assert_array_equal(running[s][cont], joint[s - 1][cont])
    for episode in rollout.episodes:
        assert episode["ticks"] <= 150
    # Stored log-probs are the conditional's, recomputable from the stored rows.
    batch = rollout.training_batch(
        np.zeros((rollout.num_steps, 3)), np.zeros((rollout.num_steps, 3))
    )
    with torch.no_grad():
        dist = policy.distribution(batch.obs, batch.choosing, batch.running, batch.available)
        torch.testing.assert_close(dist.log_prob(batch.joint), batch.old_log_prob)


@pytest.mark.parametrize("backend", ["local", "processes"])
def test_state_dict_replays_every_environment_exactly(envs, backend):
    envs.reset()
    _learner(envs, 250).collect(envs)
    state = envs.state_dict()

    twin = SeededVectorEnv(CONFIG, num_envs=3, seed=11, backend=backend, num_workers=2)
    try:
        twin.load_state_dict(state)
        for a, b in zip(envs.points, twin.points, strict=True):
            assert a.ticks == b.ticks
            for va, vb in zip(a.vectors, b.vectors, strict=True):
                np.testing.assert_array_equal(va, vb)
            np.testing.assert_array_equal(a.choosing, b.choosing)
            np.testing.assert_array_equal(a.running, b.running)
        first = _learner(envs, 300, seed=3).collect(envs)
        second = _learner(twin, 300, seed=3).collect(twin)
        for key in ("joint", "reward_sum", "duration", "terminated", "truncated"):
            np.testing.assert_array_equal(first.grid(key), second.grid(key))

        state["actions"][1] = state["actions"][1][:-1]  # drop environment 1's last option
        with pytest.raises(RuntimeError, match=r"environments \[1\] did not reproduce"):
            twin.load_state_dict(state)
    finally:
        twin.close()


def test_the_rollouts_values_are_the_critics_own_to_the_bit(envs):
    """What the rollout keeps is exactly what the critic computes alone, one point at a time,
    with no autograd graph, and each bootstrap is the next row's value unless that
    environment's episode was truncated between them."""
    envs.reset()
    learner = _learner(envs, 600)  # past every environment's first 150-tick episode
    rollout = learner.collect(envs)
    with torch.no_grad():
        for t in range(rollout.num_steps):
            value = learner.critic.value(ObsBatch(vectors=rollout.vectors[t]))
            assert torch.equal(rollout.value[t], value)
            assert not rollout.value[t].requires_grad and not rollout.next_value[t].requires_grad
    truncated = rollout.grid("truncated")
    assert truncated.any() and not truncated.all()  # both cases below occur
    for t in range(rollout.num_steps - 1):
        kept = ~truncated[t]
        assert torch.equal(rollout.next_value[t][kept], rollout.value[t + 1][kept])
