"""Exploration inside PPO: a rollout collected with ε-mixed sampling is scored by the update as
it was collected, so at the weights that collected it the ratio is 1 in every row (no KL, no
clipping) — for each form and each ratio — and exploration changes what the update is told
(the recorded log-probabilities are the behaviour's, not the policy's)."""

from __future__ import annotations

import pytest
import torch

from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.learner import LearnerSetup, MAPPOLearner, PPOConfig
from maopg.policy import AutoregressivePolicy, CentralizedPolicy, PartiallyCentralizedPolicy

CONFIG = EnvConfig(task="box_pushing_grid", strategy="continue", overrides={"size": 4})
POLICIES = {
    "async": CentralizedPolicy,
    "partial": PartiallyCentralizedPolicy,
    "async-ar": AutoregressivePolicy,
}


def _rollout_and_learner(policy: str, **explore):
    envs = SeededVectorEnv(CONFIG, num_envs=3, seed=5)
    envs.reset()
    torch.manual_seed(0)
    config = PPOConfig(explore_eps=0.6, **explore)
    setup = LearnerSetup(
        spec=envs.spec,
        config=config,
        num_envs=envs.num_envs,
        batch_ticks=150,
        gamma=0.99,
        hidden=32,
        layers=2,
        sample_gen=torch.Generator().manual_seed(1),
        update_gen=torch.Generator(),
    )
    network = POLICIES[policy](envs.spec, hidden=32)
    with torch.no_grad():  # far from uniform, so that the policy and the mixture differ
        for parameter in network.parameters():
            parameter.add_(torch.randn_like(parameter) * 0.3)
    learner = MAPPOLearner(network, setup)
    mixed = config.explore_ratio == "mixture"
    rollout = learner.collect(envs, 0.6, scored_mixed=mixed)
    envs.close()
    return learner, rollout


@pytest.mark.parametrize("ratio", ["mixture", "policy"])
@pytest.mark.parametrize("form", ["agent", "joint"])
@pytest.mark.parametrize("policy", list(POLICIES))
def test_the_update_scores_the_batch_as_it_was_collected(policy, form, ratio):
    learner, rollout = _rollout_and_learner(policy, explore_form=form, explore_ratio=ratio)
    advantages, returns, _ = rollout.advantages(None, gamma=0.99, lam=0.95, form="smdp")
    batch = rollout.training_batch(advantages, returns)
    assert (batch.epsilon is not None) == (ratio == "mixture")
    with torch.no_grad():
        losses = learner.ppo.losses(batch, batch.advantages, batch.returns)
    assert float(losses.approx_kl) == pytest.approx(0.0, abs=1e-7)
    assert float(losses.clip_fraction) == 0.0
    if ratio == "mixture":  # the recorded log-probabilities are the mixture's, not the policy's
        with torch.no_grad():
            own = learner.policy.distribution(
                batch.obs, batch.choosing, batch.running, batch.available
            ).log_prob(batch.joint)
        assert (own - batch.old_log_prob).abs().max() > 0.1
