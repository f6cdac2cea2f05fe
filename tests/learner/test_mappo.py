"""The PPO update on a fixed batch of decision points (real policy and critic networks)."""

import pytest
import torch

from maopg.env.contract import AgentSpec, EnvSpec, Strategy
from maopg.learner import MAPPO, PPOConfig, TrainBatch, ValueNorm
from maopg.policy import CentralCritic, CentralizedPolicy, ObsBatch, PartiallyCentralizedPolicy

POLICIES = {"centralized": CentralizedPolicy, "partial": PartiallyCentralizedPolicy}

SPEC = EnvSpec(
    task="fixed-batch",
    strategy=Strategy.CONTINUE,
    agents=(
        AgentSpec("a", "turtlebot", ("x", "y", "z"), 4),
        AgentSpec("b", "fetch", ("p", "q"), 3),
    ),
    image_shape=None,
    tick_seconds=0.1,
    max_ticks=10,
    gamma=0.99,
)


def _fixed_batch(policy, critic, size: int = 96) -> TrainBatch:
    gen = torch.Generator().manual_seed(0)
    obs = ObsBatch(torch.randn(size, 7, generator=gen))
    choosing = torch.rand(size, 2, generator=gen) < 0.6
    choosing[:, 0] |= ~choosing.any(dim=1)  # at least one agent chooses at a decision point
    running = torch.stack(
        [torch.randint(0, 3, (size,), generator=gen), torch.randint(0, 2, (size,), generator=gen)],
        dim=1,
    )
    available = torch.ones(size, 5, dtype=torch.bool)
    available[::3, 1] = False  # option y of agent a unavailable in every third row
    with torch.no_grad():
        dist = policy.distribution(obs, choosing, running, available)
        joint = dist.sample(gen)
        old_log_prob = dist.log_prob(joint)
        old_value = critic(obs)
    # Advantages that favour option z of agent a: a policy update can clearly exploit them.
    advantages = torch.where(joint[:, 0] == 2, 1.0, -0.5) + 0.1 * torch.randn(size, generator=gen)
    returns = 20.0 + 5.0 * obs.vectors[:, 0]
    return TrainBatch(
        obs, choosing, running, available, joint, old_log_prob, old_value, returns, advantages
    )


@pytest.mark.parametrize("kind", ["centralized", "partial"])
def test_update_lowers_the_loss_on_a_fixed_batch(kind):
    torch.manual_seed(0)
    policy = POLICIES[kind](SPEC, hidden=32)
    critic = CentralCritic(SPEC, hidden=32)
    norm = ValueNorm()
    learner = MAPPO(policy, critic, norm, PPOConfig(epochs=8, num_minibatches=2))
    batch = _fixed_batch(policy, critic)

    def total_loss() -> tuple[float, float]:
        norm_copy = ValueNorm()
        norm_copy.load_state_dict(norm.state_dict())
        norm_copy.update(batch.returns)  # the targets the update itself will regress
        adv = (batch.advantages - batch.advantages.mean()) / (batch.advantages.std() + 1e-5)
        with torch.no_grad():
            losses = learner.losses(batch, adv, norm_copy.normalize(batch.returns))
        return float(losses.policy), float(losses.value)

    policy_before, value_before = total_loss()
    stats = learner.update(batch, torch.Generator().manual_seed(1))
    # The same batch, advantages and targets (the normaliser now holds the batch, as above).
    with torch.no_grad():
        adv = (batch.advantages - batch.advantages.mean()) / (batch.advantages.std() + 1e-5)
        after = learner.losses(batch, adv, norm.normalize(batch.returns))

    assert abs(policy_before) < 0.05  # ratio 1 at the start: surrogate = −mean(adv) = 0
    assert float(after.policy) < policy_before - 0.02
    assert float(after.value) < value_before
    assert stats["approx_kl"] > 0.0
    assert 0.0 <= stats["clip_fraction"] <= 1.0
    with torch.no_grad():
        dist = policy.distribution(batch.obs, batch.choosing, batch.running, batch.available)
        new_log_prob = dist.log_prob(batch.joint)
    a_chose_z = batch.choosing[:, 0] & (batch.joint[:, 0] == 2)
    assert float((new_log_prob - batch.old_log_prob)[a_chose_z].mean()) > 0.0


def test_continuing_agents_do_not_move_the_ratio():
    """Rows where only agent b chooses: changing a's recorded option changes nothing."""
    torch.manual_seed(0)
    policy = CentralizedPolicy(SPEC, hidden=32)
    critic = CentralCritic(SPEC, hidden=32)
    learner = MAPPO(policy, critic, None, PPOConfig())
    batch = _fixed_batch(policy, critic)
    only_b = ~batch.choosing[:, 0] & batch.choosing[:, 1]
    assert only_b.sum() > 5
    altered = batch.rows(torch.nonzero(only_b).squeeze(1))
    original = learner.losses(altered, altered.advantages, altered.returns)
    altered.joint = altered.joint.clone()
    altered.joint[:, 0] = (altered.joint[:, 0] + 1) % 3
    changed = learner.losses(altered, altered.advantages, altered.returns)
    torch.testing.assert_close(changed.policy, original.policy)


def test_the_entropy_bonus_falls_linearly_over_ent_decay_ticks():
    assert PPOConfig(ent_coef=0.02).entropy_coef(10**9) == 0.02  # ent_decay=0: constant
    cfg = PPOConfig(ent_coef=0.02, ent_coef_end=0.004, ent_decay=1000)
    assert cfg.entropy_coef(0) == 0.02
    assert cfg.entropy_coef(500) == pytest.approx(0.012)
    assert cfg.entropy_coef(1000) == cfg.entropy_coef(5000) == pytest.approx(0.004)


def test_the_update_weighs_the_entropy_bonus_by_the_samples_trained():
    """The same batch from the same weights: the update after ``ent_decay`` ticks (no bonus)
    leaves a sharper policy than the first one (a large bonus), and equals an update with
    ``ent_coef=0`` throughout to the last bit."""

    def update(cfg: PPOConfig, samples: int) -> tuple[float, dict[str, torch.Tensor]]:
        torch.manual_seed(0)
        policy = CentralizedPolicy(SPEC, hidden=32)
        critic = CentralCritic(SPEC, hidden=32)
        batch = _fixed_batch(policy, critic)
        MAPPO(policy, critic, ValueNorm(), cfg).update(
            batch, torch.Generator().manual_seed(1), samples=samples
        )
        with torch.no_grad():
            dist = policy.distribution(batch.obs, batch.choosing, batch.running, batch.available)
        return float(dist.entropy().mean()), policy.state_dict()

    annealed = PPOConfig(epochs=8, lr=5e-3, ent_coef=5.0, ent_coef_end=0.0, ent_decay=100)
    soft, _ = update(annealed, samples=0)
    sharp, weights = update(annealed, samples=100)
    _, without = update(PPOConfig(epochs=8, lr=5e-3, ent_coef=0.0), samples=0)
    assert sharp < soft - 0.05
    for name, tensor in without.items():
        assert torch.equal(weights[name], tensor), name
