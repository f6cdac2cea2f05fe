"""Each distinct camera image is stored once per rollout and encoded once per update, with the
same losses and gradients as encoding every decision point's images; and the critic's steps of
an update, on a thread of their own, change no bit of its outcome."""

from __future__ import annotations

import pytest
import torch

from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.learner import MAPPO, LearnerSetup, MAPPOLearner, PPOConfig, ValueNorm
from maopg.policy import CentralCritic, CentralizedPolicy, ObsBatch, PartiallyCentralizedPolicy

POLICIES = {"centralized": CentralizedPolicy, "partial": PartiallyCentralizedPolicy}


@pytest.fixture(scope="module")
def rollout():
    """A Tool Delivery RGB rollout of 3 environments (36 px cameras)."""
    config = EnvConfig("tool_delivery", "continue", images=True, image_size=36)
    envs = SeededVectorEnv(config, num_envs=3, seed=5)
    try:
        envs.reset()
        torch.manual_seed(0)
        setup = LearnerSetup(
            spec=envs.spec,
            config=PPOConfig(),
            num_envs=3,
            batch_ticks=150,
            gamma=0.99,
            hidden=32,
            layers=2,
            sample_gen=torch.Generator().manual_seed(1),
            update_gen=torch.Generator(),
        )
        learner = MAPPOLearner(CentralizedPolicy(envs.spec, hidden=32, cnn_features=16), setup)
        return envs.spec, learner.collect(envs)
    finally:
        envs.close()


def test_the_rollout_stores_each_image_once(rollout):
    _, rollout = rollout
    batch = rollout.training_batch(*[torch.zeros(rollout.num_steps, 3).numpy()] * 2)
    dense = batch.obs.dense_images()
    rows, agents = batch.choosing.shape
    assert dense.shape == (rows, agents, 36, 36, 3)
    # every stored image is one a choosing agent saw (or the first row's); none is repeated
    assert batch.obs.images.shape[0] == int(batch.choosing[3:].sum()) + 3 * agents
    assert batch.obs.images.shape[0] < 0.7 * rows * agents
    # a continuing agent's image is the one it saw at its last decision (same bank entry)
    index = batch.obs.image_index.view(rollout.num_steps, 3, agents)
    choosing = batch.choosing.view(rollout.num_steps, 3, agents)
    assert torch.equal(index[1:][~choosing[1:]], index[:-1][~choosing[1:]])


@pytest.mark.parametrize("kind", ["centralized", "partial"])
def test_banked_and_dense_batches_give_the_same_losses_and_gradients(rollout, kind):
    spec, rollout = rollout
    steps = rollout.num_steps
    advantages = torch.randn(steps, 3, generator=torch.Generator().manual_seed(2)).numpy()
    batch = rollout.training_batch(advantages, advantages + 1.0)
    dense = ObsBatch(batch.obs.vectors, batch.obs.dense_images())
    grads = []
    for obs in (batch.obs, dense):
        torch.manual_seed(3)
        policy = POLICIES[kind](spec, hidden=32, cnn_features=16)
        critic = CentralCritic(spec, hidden=32, cnn_features=16)
        ppo = MAPPO(policy, critic, ValueNorm(), PPOConfig())
        rows = batch.rows(torch.arange(len(batch)))
        rows.obs = obs
        losses = ppo.losses(rows, rows.advantages, rows.returns)
        total = losses.policy - 0.01 * losses.entropy + losses.value
        total.backward()
        grads.append(
            (
                [float(x.detach()) for x in (losses.policy, losses.value, losses.entropy)],
                [p.grad.clone() for p in [*policy.parameters(), *critic.parameters()]],
            )
        )
    (loss_a, grad_a), (loss_b, grad_b) = grads
    assert loss_a == pytest.approx(loss_b, abs=1e-6)
    for a, b in zip(grad_a, grad_b, strict=True):
        torch.testing.assert_close(a, b, rtol=1e-6, atol=1e-6)


def test_a_minibatch_keeps_only_the_images_it_uses(rollout):
    _, rollout = rollout
    batch = rollout.training_batch(*[torch.zeros(rollout.num_steps, 3).numpy()] * 2)
    part = batch.rows(torch.arange(0, len(batch), 4))
    assert part.obs.images.shape[0] == int(torch.unique(batch.obs.image_index[::4]).numel())
    assert torch.equal(part.obs.dense_images(), batch.obs.dense_images()[::4])


@pytest.mark.parametrize("kind", ["centralized", "partial"])
def test_the_critic_on_its_own_thread_changes_no_bit_of_the_update(rollout, update_both_ways, kind):
    spec, rollout = rollout
    advantages = torch.randn(rollout.num_steps, 3, generator=torch.Generator().manual_seed(2))
    batch = rollout.training_batch(advantages.numpy(), advantages.numpy() + 1.0)

    def make() -> MAPPO:
        torch.manual_seed(3)
        policy = POLICIES[kind](spec, hidden=32, cnn_features=16)
        critic = CentralCritic(spec, hidden=32, cnn_features=16)
        return MAPPO(policy, critic, ValueNorm(), PPOConfig(epochs=3, num_minibatches=2))

    threads, inline = update_both_ways(make, batch)
    assert threads["stats"] == inline["stats"]
    for name, value in threads["weights"].items():
        assert torch.equal(value, inline["weights"][name]), name
