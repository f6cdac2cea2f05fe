"""Recurrent option policies and critic (:mod:`maopg.policy.memory`) on real Tool Delivery
decision points: where the GRU state advances, where it restarts, and that the chunked forward
of training computes what the step-by-step forward of collection computed."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from maopg.env import make_env
from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.learner import LearnerSetup, MAPPOLearner, PPOConfig
from maopg.learner.mappo import (
    autoregressive_policy,
    centralized_policy,
    partial_factored_policy,
    partial_policy,
)
from maopg.policy import (
    AutoregressivePolicy,
    DistributionActor,
    MemoryDesign,
    OptionMemory,
    PartialFactoredPolicy,
    PartiallyCentralizedPolicy,
)
from maopg.policy.joint_size import BuildTarget

SHORT = {"max_ticks": 25}
"""Episodes of 25 ticks: several end inside a rollout, and inside training chunks."""


@pytest.mark.parametrize(
    ("policy_class", "joint_slots"),
    [(PartiallyCentralizedPolicy, 0), (PartialFactoredPolicy, 0), (AutoregressivePolicy, 1)],
)
def test_per_agent_states_freeze_while_an_agent_continues_and_restart_with_an_episode(
    policy_class, joint_slots
):
    """Agent i's own state advances only at its decisions; a joint state (the autoregressive
    policy's, before the agents' own) at every decision point."""
    torch.manual_seed(0)
    env = make_env("tool_delivery", "continue", seed=0, overrides=SHORT)
    policy = policy_class(env.spec, hidden=16, memory=MemoryDesign(recurrent=True))
    actor = DistributionActor(policy, greedy=False, seed=1)
    fresh = policy.initial_state(1)
    seen = {"frozen": 0, "advanced": 0, "restarts": 0}
    episode = 0
    try:
        point = env.reset(seed=episode)
        for _ in range(40):
            before = actor.state.clone()
            joint = actor(point)
            after = actor.state
            if point.ticks == 0:
                # A reset point reads the zero state, whatever the previous episode left.
                twin = DistributionActor(policy, greedy=False, seed=1)
                twin(point)
                torch.testing.assert_close(after, twin.state, rtol=0, atol=0)
                seen["restarts"] += int(bool(before.abs().sum() > 0))
            else:
                for slot in range(joint_slots):
                    assert not torch.equal(after[0, slot], before[0, slot]), point.ticks
                for agent, choosing in enumerate(point.choosing, start=joint_slots):
                    same = torch.equal(after[0, agent], before[0, agent])
                    assert same != bool(choosing), (point.ticks, agent, choosing)
                    seen["frozen" if same else "advanced"] += 1
            point = env.step(joint)
            if point.done:
                episode += 1
                point = env.reset(seed=episode)
    finally:
        env.close()
    assert fresh.abs().sum() == 0
    assert seen["frozen"] > 0 and seen["advanced"] > 0 and seen["restarts"] >= 1, seen


def _learner(envs: SeededVectorEnv, builder, memory: dict[str, bool]) -> MAPPOLearner:
    torch.manual_seed(0)
    config = PPOConfig(recurrent=True, chunk_length=5, epochs=2, **memory)
    setup = LearnerSetup(
        spec=envs.spec,
        config=config,
        num_envs=envs.num_envs,
        batch_ticks=80,
        gamma=0.99,
        hidden=16,
        layers=1,
        sample_gen=torch.Generator().manual_seed(3),
        update_gen=torch.Generator().manual_seed(4),
    )
    target = BuildTarget.this_machine()
    policy = builder(envs.spec, hidden=16, layers=1, config=config, target=target)
    return MAPPOLearner(policy, setup)


@pytest.mark.parametrize(
    ("builder", "memory"),
    [
        (centralized_policy, {}),
        (partial_policy, {}),
        (autoregressive_policy, {}),
        (partial_factored_policy, {}),
        # the GRUs read the options too, and are layer-normalised
        (centralized_policy, {"option_history": True, "memory_norm": True}),
        (partial_policy, {"option_history": True, "memory_norm": True}),
        (autoregressive_policy, {"memory_norm": True}),
    ],
)
def test_the_chunked_forward_equals_the_step_by_step_forward_of_collection(
    builder, memory, update_both_ways
):
    envs = SeededVectorEnv(
        EnvConfig(task="tool_delivery", strategy="continue", overrides=SHORT), num_envs=2, seed=7
    )
    try:
        envs.reset()
        learner = _learner(envs, builder, memory)
        setup = learner.setup
        learner.setup = dataclasses.replace(setup, batch_ticks=10)
        learner.collect(envs)  # the next rollout starts mid-episode, from carried states
        learner.setup = setup
        rollout = learner.collect(envs)
    finally:
        envs.close()
    steps = rollout.num_steps
    advantages, returns, _ = rollout.advantages(None, gamma=0.99, lam=0.95, form="smdp")
    batch = rollout.training_batch(advantages, returns)
    assert batch.starts.sum() >= 2  # episodes end inside the rollout
    assert not batch.starts[:2].any() and batch.policy_state[:2].abs().min() > 0
    chunks = batch.chunks(5)
    valid = chunks >= 0
    assert chunks.shape[1] == 5 and steps > 5
    resets_inside = batch.starts[chunks.clamp(min=0)][:, 1:] & valid[:, 1:]
    assert resets_inside.any()
    assert sorted(chunks[valid].tolist()) == list(range(len(batch)))  # every row once
    padded = torch.where(valid, chunks, chunks[:, :1]).flatten()
    rows = batch.rows(padded)
    starts = batch.starts[padded].view(valid.shape)
    kept = chunks[valid]
    with torch.no_grad():
        dist = learner.policy.sequence(
            rows.obs,
            rows.choosing,
            rows.running,
            rows.available,
            batch.policy_state[chunks[:, 0]],
            starts,
            valid,
        )
        values = learner.critic.sequence(
            rows.obs, batch.critic_state[chunks[:, 0]], starts, valid, rows.choosing, rows.running
        )
        log_prob = dist.log_prob(batch.joint[kept])
    torch.testing.assert_close(log_prob, batch.old_log_prob[kept], rtol=1e-5, atol=1e-6)
    torch.testing.assert_close(values, batch.old_value[kept], rtol=1e-5, atol=1e-6)

    # The PPO update runs on these chunks, the critic's steps on their own thread (the same bits
    # as on this one), and backpropagation reaches both GRUs.
    threads, inline = update_both_ways(lambda: _learner(envs, builder, memory).ppo, batch)
    assert threads["stats"] == inline["stats"]
    for name, value in threads["weights"].items():
        assert torch.equal(value, inline["weights"][name]), name
    memories = (learner.policy.memory, learner.critic.memory)
    before = [{k: v.clone() for k, v in m.state_dict().items()} for m in memories]
    stats = learner.ppo.update(batch, learner.setup.update_gen)
    assert stats["entropy"] > 0 and np.isfinite(stats["policy_loss"])
    for memory, old in zip(memories, before, strict=True):
        for slot, cell in enumerate(memory.cells):  # every slot's GRU learnt
            changed = (
                not torch.equal(old[f"cells.{slot}.{k}"], v) for k, v in cell.state_dict().items()
            )
            assert any(changed), slot


def test_recurrent_policies_refuse_the_feed_forward_path():
    env = make_env("tool_delivery", seed=0)
    try:
        spec = env.spec
    finally:
        env.close()
    policy = PartiallyCentralizedPolicy(spec, hidden=8, memory=MemoryDesign(recurrent=True))
    with pytest.raises(RuntimeError, match="step"):
        policy.distribution(None, None, None, None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"ppo\.recurrent=true"):
        _learner_with(spec, PartiallyCentralizedPolicy(spec, hidden=8))
    with pytest.raises(ValueError, match=r"ppo\.chunk_length must be >= 1"):
        PPOConfig(recurrent=True, chunk_length=0).validate()


def _learner_with(spec, policy) -> MAPPOLearner:
    setup = LearnerSetup(
        spec=spec,
        config=PPOConfig(recurrent=True),
        num_envs=1,
        batch_ticks=10,
        gamma=0.99,
        hidden=8,
        layers=1,
        sample_gen=torch.Generator(),
        update_gen=torch.Generator(),
    )
    return MAPPOLearner(policy, setup)


def test_the_option_history_tells_apart_points_whose_features_are_the_same():
    """``ppo.option_history``: at a jar the features hardly change from one ``Fill`` to the
    next, so a GRU fed only them returns to one state; fed the options too, it does not."""
    torch.manual_seed(0)
    counts = (3, 2)
    memory = OptionMemory(4, slots=1, option_counts=counts)
    features = [torch.ones(3, 4)]
    choosing = torch.tensor([[True, False], [True, False], [False, True]])
    running = torch.tensor([[-1, 1], [0, 1], [0, 1]])
    history = memory.history(choosing, running)
    assert history.tolist() == [
        [0, 0, 0, 0, 1, 1, 0],  # reset: the chooser has no option yet
        [1, 0, 0, 0, 1, 1, 0],
        [1, 0, 0, 0, 1, 0, 1],
    ]
    no_starts = torch.zeros(3, dtype=torch.bool)
    outputs, _ = memory.step(features, memory.initial_state(3), no_starts, history=history)
    assert not torch.equal(outputs[0][0], outputs[0][1])
    assert not torch.equal(outputs[0][1], outputs[0][2])
    with pytest.raises(ValueError, match="history="):
        memory.step(features, memory.initial_state(3), no_starts)
    with pytest.raises(ValueError, match="history="):
        OptionMemory(4).step(features, torch.zeros(3, 1, 4), no_starts, history=history)
    with pytest.raises(ValueError, match=r"ppo\.option_history=true .* ppo\.recurrent=true"):
        PPOConfig(option_history=True).validate()
    with pytest.raises(ValueError, match="recurrent"):
        MemoryDesign(option_history=True)


def test_a_normalised_memory_reads_features_of_any_scale_alike():
    """``ppo.memory_norm``: the encoders' ReLU features are large (hundreds in norm) and would
    saturate the GRU's gates; normalised, a cell reads features ×1000 as it reads them ×1, and
    the head reads a normalised output while the state carried on is the cell's own."""
    torch.manual_seed(0)
    memory = OptionMemory(8, slots=2, norm=True)
    features = [torch.randn(3, 8).relu(), torch.randn(3, 8).relu() + 0.1]
    no_starts = torch.zeros(3, dtype=torch.bool)
    state = memory.initial_state(3)
    outputs, after = memory.step(features, state, no_starts)
    _, after_scaled = memory.step([1000 * x for x in features], state, no_starts)
    torch.testing.assert_close(after_scaled, after, rtol=1e-4, atol=1e-5)
    for slot, out in enumerate(outputs):
        torch.testing.assert_close(out.mean(-1), torch.zeros(3), rtol=0, atol=1e-5)
        assert not torch.allclose(out, after[:, slot])  # the state is not the output
    raw = OptionMemory(8, slots=2)
    raw.cells.load_state_dict(memory.cells.state_dict())
    _, saturated = raw.step([1000 * x for x in features], state, no_starts)
    assert not torch.allclose(saturated, after, atol=1e-2)
    with pytest.raises(ValueError, match=r"ppo\.memory_norm=true .* ppo\.recurrent=true"):
        PPOConfig(memory_norm=True).validate()
    with pytest.raises(ValueError, match="recurrent"):
        MemoryDesign(norm=True)
