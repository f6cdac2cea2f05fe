"""The round-based learners of the literature (ACAC, Mac-IAICC) keep to the options a task makes
available: on Tool Delivery with ``mask_options=true`` (the initiation sets the teams-of-eight
board masks with), every option a choosing agent draws in a round, from its ε-mixed policy, is one
its mask allowed, and its mixed log-probability of every masked option is −∞ (so an update never
reads one)."""

import dataclasses

import pytest
import torch

from maopg.env.vector import EnvConfig, SeededVectorEnv
from maopg.learner import ACACConfig, ACACLearner
from maopg.learner.mac_iaicc import MacIAICCConfig, MacIAICCLearner
from maopg.policy.agent_centric import AgentCentricPolicy

LEARNERS = {
    "acac": (ACACLearner, ACACConfig, {}),
    "mac-iaicc": (MacIAICCLearner, MacIAICCConfig, {"embed_time": False, "head_norm": False}),
}


@pytest.mark.parametrize("method", list(LEARNERS))
def test_a_round_draws_only_available_options(setup_for, method):
    config = EnvConfig(
        task="tool_delivery",
        strategy="continue",
        overrides={"mask_options": True, "max_ticks": 60},
    )
    envs = SeededVectorEnv(config, num_envs=2, seed=0)
    try:
        envs.reset()
        learner_class, config_class, policy_settings = LEARNERS[method]
        torch.manual_seed(0)
        setup = setup_for(envs, config_class(episodes_per_update=2))
        learner = learner_class(AgentCentricPolicy(envs.spec, **policy_settings), setup)
        batch, _, _ = learner.collect(envs, 0.5)
        counts = [len(agent.option_names) for agent in envs.spec.agents]
        offsets = torch.tensor([0, *counts[:-1]]).cumsum(0)
        deciding = batch.choosing & batch.steps.unsqueeze(-1)
        allowed = batch.available.gather(-1, batch.joint + offsets)
        assert allowed[deciding].all()
        log_probs, _ = learner.agent_log_probs(batch, 0.5)
        masked_any = False
        for i, (offset, count) in enumerate(zip(offsets.tolist(), counts, strict=True)):
            mine = deciding[..., i]
            masked = ~batch.available[..., offset : offset + count][mine]
            masked_any |= bool(masked.any())
            for option in range(count):
                joint = batch.joint.clone()
                joint[..., i] = option
                probe = dataclasses.replace(batch, joint=joint)
                lp = learner.agent_log_probs(probe, 0.5)[0][i][mine]
                assert torch.isneginf(lp[masked[:, option]]).all()
                assert torch.isfinite(lp[~masked[:, option]]).all()
            assert torch.isfinite(log_probs[i][mine]).all()
        assert masked_any  # the masks did mask some choosing agent's options
    finally:
        envs.close()
