"""Batching, encoders, policies and critic: shapes, information flow, init and determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from torch import nn

from maopg.env.contract import AgentSpec, DecisionPoint, EnvSpec, Strategy
from maopg.policy import (
    CentralCritic,
    CentralizedPolicy,
    ConditionalJoint,
    FactoredConditional,
    JointEncoder,
    LocalEncoder,
    NatureCNN,
    ObsBatch,
    PartiallyCentralizedPolicy,
    conditional_log_probs,
    stack_conditions,
    vector_slices,
)

POLICIES = {"centralized": CentralizedPolicy, "partial": PartiallyCentralizedPolicy}


def make_spec(image_px: int | None = None) -> EnvSpec:
    """Tool-Delivery-shaped spec: two Turtlebots (3 options) and a Fetch (6 options)."""
    turtle = ("GoToWS", "GoToTR", "GetTool")
    fetch = ("Wait", "PassTo0", "PassTo1", "Search0", "Search1", "Search2")
    return EnvSpec(
        task="tool_delivery",
        strategy=Strategy.CONTINUE,
        agents=(
            AgentSpec("turtlebot0", "turtlebot", turtle, 5),
            AgentSpec("turtlebot1", "turtlebot", turtle, 5),
            AgentSpec("fetch", "fetch", fetch, 3),
        ),
        image_shape=None if image_px is None else (image_px, image_px, 3),
        tick_seconds=1.0,
        max_ticks=150,
        gamma=0.99,
    )


def random_obs(spec: EnvSpec, batch: int, seed: int) -> ObsBatch:
    gen = torch.Generator().manual_seed(seed)
    vectors = torch.randn(batch, sum(a.vector_size for a in spec.agents), generator=gen)
    images = None
    if spec.image_shape is not None:
        shape = (batch, spec.num_agents, *spec.image_shape)
        images = torch.randint(0, 256, shape, generator=gen, dtype=torch.uint8)
    return ObsBatch(vectors, images)


def all_choose(spec: EnvSpec, batch: int):
    return (
        torch.ones(batch, spec.num_agents, dtype=torch.bool),
        torch.full((batch, spec.num_agents), -1),
        torch.ones(batch, sum(spec.option_counts), dtype=torch.bool),
    )


def decision_point(spec: EnvSpec, rng: np.random.Generator) -> DecisionPoint:
    n = spec.num_agents
    images = None
    if spec.image_shape is not None:
        images = rng.integers(0, 256, (n, *spec.image_shape), dtype=np.uint8)
    return DecisionPoint(
        vectors=tuple(rng.standard_normal(a.vector_size).astype(np.float32) for a in spec.agents),
        images=images,
        choosing=rng.random(n) < 0.5,
        running=rng.integers(0, 3, n),
        available=tuple(rng.random(k) < 0.8 for k in spec.option_counts),
    )


def test_batching_decision_points_copies_and_banks_images():
    spec = make_spec(image_px=36)
    rng = np.random.default_rng(0)
    points = [decision_point(spec, rng) for _ in range(4)]
    obs = ObsBatch.from_decision_points(points)
    assert obs.vectors.dtype == torch.float32 and obs.vectors.shape == (4, 13)
    assert obs.images.dtype == torch.uint8 and obs.images.shape == (4, 3, 36, 36, 3)
    slices = vector_slices(spec)
    assert slices == (slice(0, 5), slice(5, 10), slice(10, 13))
    np.testing.assert_array_equal(obs.vectors[2, slices[1]].numpy(), points[2].vectors[1])
    np.testing.assert_array_equal(obs.images[3].numpy(), points[3].images)
    choosing, running, available = stack_conditions(points)
    assert choosing.dtype == torch.bool and running.dtype == torch.int64
    assert available.shape == (4, 12)
    np.testing.assert_array_equal(available[1, 3:6].numpy(), points[1].available[1])
    # The environment reuses its buffers: the batch must not see later writes.
    before = obs.vectors.clone(), obs.images.clone()
    points[0].vectors[0][:] = 99.0
    points[0].images[:] = 7
    assert torch.equal(obs.vectors, before[0]) and torch.equal(obs.images, before[1])
    sub = obs[torch.tensor([3, 1])]
    assert torch.equal(sub.vectors[0], obs.vectors[3]) and torch.equal(sub.images[1], obs.images[1])
    # the banked form: a bank of distinct images and per-point indices into it
    bank = ObsBatch(obs.vectors, obs.images.flatten(0, 1), torch.arange(12).view(4, 3))
    assert torch.equal(bank.dense_images(), obs.images)
    picked = bank[torch.tensor([3, 1])]
    assert picked.images.shape[0] == 6 and torch.equal(picked.dense_images(), sub.images)


@pytest.mark.parametrize(("px", "flat"), [(36, 64), (64, 1024), (84, 3136)])
def test_nature_cnn_shapes(px, flat):
    cnn = NatureCNN((px, px, 3), features=128)
    assert cnn.fc[0].in_features == flat
    out = cnn(torch.randint(0, 256, (5, px, px, 3), dtype=torch.uint8))
    assert out.shape == (5, 128) and out.min() >= 0
    non_square = NatureCNN((48, 64, 3), features=32)
    assert non_square(torch.zeros(2, 48, 64, 3, dtype=torch.uint8)).shape == (2, 32)
    with pytest.raises(ValueError):
        NatureCNN((32, 64, 3))


def test_nature_cnn_scales_pixels_to_unit_range():
    torch.manual_seed(0)
    cnn = NatureCNN((64, 64, 3), features=16)
    white = torch.full((1, 64, 64, 3), 255, dtype=torch.uint8)
    gray = torch.full((1, 64, 64, 3), 51, dtype=torch.uint8)
    with torch.no_grad():
        torch.testing.assert_close(cnn(white), cnn.fc(cnn.convs(torch.ones(1, 3, 64, 64))))
        torch.testing.assert_close(cnn(gray), cnn.fc(cnn.convs(torch.full((1, 3, 64, 64), 0.2))))
    with pytest.raises(TypeError):
        cnn(white.float())


@pytest.mark.parametrize("px", [64, 84])
def test_joint_encoder_shares_one_cnn_across_agents(px):
    spec = make_spec(image_px=px)
    encoder = JointEncoder(spec, hidden=64, cnn_features=32)
    assert sum(isinstance(m, NatureCNN) for m in encoder.modules()) == 1
    assert sum(isinstance(m, nn.Conv2d) for m in encoder.modules()) == 3
    obs = random_obs(spec, batch=4, seed=1)
    assert encoder(obs).shape == (4, 64) and encoder.out_dim == 64
    assert encoder.mlp[0].in_features == 13 + 3 * 32
    obs.images[:, 2] = obs.images[:, 0]  # the Fetch sees what Turtlebot 0 sees
    with torch.no_grad():
        features = encoder.image_features(obs)
    assert features.shape == (4, 3, 32)
    torch.testing.assert_close(features[:, 2], features[:, 0])
    assert not torch.allclose(features[:, 1], features[:, 0])


def test_encoders_without_images():
    spec = make_spec()
    encoder = JointEncoder(spec, hidden=32)
    assert encoder.cnn is None and encoder(random_obs(spec, 3, 0)).shape == (3, 32)
    ignoring = JointEncoder(make_spec(image_px=64), hidden=32, use_images=False)
    assert ignoring.cnn is None
    assert ignoring(random_obs(make_spec(image_px=64), 3, 0)).shape == (3, 32)
    with pytest.raises(ValueError):
        JointEncoder(spec, use_images=True)


def test_local_encoder_reads_only_its_agent():
    spec = make_spec(image_px=36)
    encoder = LocalEncoder(spec, agent=1, hidden=32, cnn_features=16)
    obs = random_obs(spec, batch=3, seed=2)
    obs.vectors.requires_grad_(True)
    out = encoder(obs)
    assert out.shape == (3, 32)
    out.sum().backward()
    grad_columns = obs.vectors.grad.abs().sum(dim=0) > 0
    assert grad_columns.tolist() == [False] * 5 + [True] * 5 + [False] * 3
    with torch.no_grad():
        changed = ObsBatch(obs.vectors.detach().clone(), obs.images.clone())
        changed.images[:, [0, 2]] = 0
        changed.vectors[:, 10:] = 5.0
        torch.testing.assert_close(encoder(changed), out.detach())
        changed.images[:, 1] = 0
        assert not torch.allclose(encoder(changed), out.detach())


def test_seeded_construction_is_deterministic():
    spec = make_spec(image_px=64)
    obs = random_obs(spec, batch=2, seed=3)
    outputs = []
    for _ in range(2):
        torch.manual_seed(123)
        policy, critic = CentralizedPolicy(spec, hidden=32), CentralCritic(spec, hidden=32)
        with torch.no_grad():
            outputs.append((policy.joint_logits(obs), critic.value(obs)))
    torch.testing.assert_close(outputs[0], outputs[1], rtol=0, atol=0)
    torch.manual_seed(124)
    with torch.no_grad():
        assert not torch.equal(CentralizedPolicy(spec, hidden=32).joint_logits(obs), outputs[0][0])


def test_centralized_policy_distribution_and_init():
    spec = make_spec()
    torch.manual_seed(0)
    policy = CentralizedPolicy(spec, hidden=64)
    assert isinstance(policy, CentralizedPolicy)
    obs = random_obs(spec, batch=6, seed=4)
    logits = policy.joint_logits(obs)
    assert logits.shape == (6, 3, 3, 6)
    # 0.01 head gain: the initial policy is close to uniform over the 54 joint options.
    assert logits.abs().max() < 0.1
    choosing = torch.tensor([[True, False, True]] * 6)
    running = torch.tensor([[-1, 2, -1]] * 6)
    available = torch.ones(6, 12, dtype=torch.bool)
    dist = policy.distribution(obs, choosing, running, available)
    assert isinstance(dist, ConditionalJoint)
    torch.testing.assert_close(
        dist.log_probs, conditional_log_probs(logits, choosing, running, available)
    )
    assert torch.allclose(dist.entropy(), torch.full((6,), math.log(18)), atol=1e-2)
    joint = dist.sample(torch.Generator().manual_seed(0))
    assert torch.all(joint[:, 1] == 2)


def test_partially_centralized_policy_uses_local_observations():
    spec = make_spec()
    policy = PartiallyCentralizedPolicy(spec, hidden=32)
    assert isinstance(policy, PartiallyCentralizedPolicy)
    obs = random_obs(spec, batch=4, seed=5)
    obs.vectors.requires_grad_(True)
    per_agent = policy.agent_joint_logits(obs)
    slices = vector_slices(spec)
    for i, logits in enumerate(per_agent):
        assert logits.shape == (4, 3, 3, 6)
        (grad,) = torch.autograd.grad(logits.sum(), obs.vectors)
        touched = grad.abs().sum(dim=0) > 0
        assert touched[slices[i]].all() and touched.sum() == slices[i].stop - slices[i].start
    dist = policy.distribution(obs, *all_choose(spec, 4))
    assert isinstance(dist, FactoredConditional)
    assert dist.sample().shape == (4, 3)


def test_central_critic_reads_all_agents():
    spec = make_spec(image_px=36)
    critic = CentralCritic(spec, hidden=32, cnn_features=16)
    obs = random_obs(spec, batch=5, seed=6)
    obs.vectors.requires_grad_(True)
    values = critic(obs)
    assert values.shape == (5,)
    values.sum().backward()
    assert (obs.vectors.grad.abs().sum(dim=0) > 0).all()


@pytest.mark.parametrize("kind", ["centralized", "partial"])
def test_gradient_steps_raise_the_probability_of_a_target(kind):
    spec = make_spec(image_px=36)
    torch.manual_seed(0)
    policy = POLICIES[kind](spec, hidden=32, cnn_features=16)
    obs = random_obs(spec, batch=8, seed=7)
    choosing = torch.tensor([[True, True, True], [False, True, False]] * 4)
    running = torch.tensor([[-1, -1, -1], [1, -1, 4]] * 4)
    available = torch.ones(8, 12, dtype=torch.bool)
    target = torch.tensor([[2, 0, 3], [1, 1, 4]] * 4)
    optimiser = torch.optim.Adam(policy.parameters(), lr=1e-2)
    before = policy.distribution(obs, choosing, running, available).log_prob(target).detach()
    for step in range(20):
        loss = -policy.distribution(obs, choosing, running, available).log_prob(target).mean()
        optimiser.zero_grad()
        loss.backward()
        if step == 0:  # the loss reaches every layer, the shared camera CNN(s) included
            grads = {name: p.grad for name, p in policy.named_parameters()}
            assert any("cnn" in name for name in grads)
            assert all(g is not None and g.abs().sum() > 0 for g in grads.values())
        optimiser.step()
    after = policy.distribution(obs, choosing, running, available).log_prob(target).detach()
    assert torch.all(after > before + 0.5)
