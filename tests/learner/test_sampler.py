"""Rollout collection on the real Tool Delivery environment."""

import numpy as np
import pytest
import torch

from maopg.learner import EnvConfig, Sampler
from maopg.policy import CentralCritic, build_policy

CONFIG = EnvConfig(task="tool_delivery", strategy="continue")


@pytest.fixture
def networks():
    torch.manual_seed(0)
    sampler = Sampler(CONFIG, num_envs=3, num_workers=0, seed=11)
    policy = build_policy("centralized", sampler.spec, hidden=32)
    critic = CentralCritic(sampler.spec, hidden=32)
    yield sampler, policy, critic
    sampler.close()


def test_rollout_counts_ticks_and_respects_the_condition(networks):
    sampler, policy, critic = networks
    sampler.reset()
    rollout = sampler.collect(policy, critic, batch_ticks=400, generator=torch.Generator())
    durations = rollout.grid("duration")
    assert 400 <= rollout.ticks == int(durations.sum()) < 400 + 3 * 150
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


def test_state_dict_replays_every_environment_exactly(networks):
    sampler, policy, critic = networks
    sampler.reset()
    sampler.collect(policy, critic, batch_ticks=250, generator=torch.Generator().manual_seed(0))
    state = sampler.state_dict()
    gen_state = torch.Generator().manual_seed(3).get_state()

    twin = Sampler(CONFIG, num_envs=3, num_workers=0, seed=11)
    try:
        twin.load_state_dict(state)
        for a, b in zip(sampler.points, twin.points, strict=True):
            assert a.ticks == b.ticks
            for va, vb in zip(a.vectors, b.vectors, strict=True):
                np.testing.assert_array_equal(va, vb)
            np.testing.assert_array_equal(a.choosing, b.choosing)
            np.testing.assert_array_equal(a.running, b.running)
        gens = [torch.Generator(), torch.Generator()]
        for g in gens:
            g.set_state(gen_state)
        first = sampler.collect(policy, critic, batch_ticks=300, generator=gens[0])
        second = twin.collect(policy, critic, batch_ticks=300, generator=gens[1])
        for key in ("joint", "reward_sum", "duration", "terminated", "truncated"):
            np.testing.assert_array_equal(first.grid(key), second.grid(key))

        state["actions"][1] = state["actions"][1][:-1]  # drop environment 1's last option
        with pytest.raises(RuntimeError, match=r"environments \[1\] did not reproduce"):
            twin.load_state_dict(state)
    finally:
        twin.close()
